"""Parameters of a jitter environment: the world's (`SceneParams`) plus task, reward and
the reward's optional shaping."""

from __future__ import annotations

from dataclasses import dataclass

from lgmd_sim.core.params import in_range, non_negative, one_of, param
from lgmd_sim.world.params import DESIGN, SceneParams


@dataclass(frozen=True)
class EnvParams(SceneParams):
    """Everything `gym.make(id, **overrides)` accepts."""

    time_limit: float = param(20.0, DESIGN, check=in_range(0.1, 3600.0),
                              doc="episode length (s); truncated after time_limit * fps steps")
    progress_reward: float = param(1.0, DESIGN, check=non_negative,
                                   doc="reward per metre of progress towards the goal")
    collision_penalty: float = param(10.0, DESIGN, check=non_negative,
                                     doc="penalty on the step of a collision")
    effort_penalty: float = param(0.01, DESIGN, check=non_negative,
                                  doc="penalty per step times the squared action norm")
    # Shaping, off by default: with the task's reward alone a goal behind six obstacles is
    # never reached by chance, and a policy that wanders earns about what one that arrives
    # does. Each is added to the reward only; info["task_reward"] keeps the task's.
    goal_bonus: float = param(0.0, "design: off; a reward for arriving, not only for "
                              "approaching", check=non_negative,
                              doc="reward added once, on the step the goal is reached")
    time_penalty: float = param(0.0, "design: off; makes dawdling cost", check=non_negative,
                                doc="penalty per second of the episode")
    proximity_penalty: float = param(0.0, "design: off; warns before the collision penalty, "
                                     "where the Oracle would start to avoid",
                                     check=non_negative,
                                     doc="penalty per second while the threat is in the "
                                         "Oracle's trigger zone (lgmd_sim.envs.zone)")
    terminate_on_collision: bool = param(True, DESIGN, check=one_of(True, False),
                                         doc="end the episode at the first collision")

    @property
    def max_steps(self) -> int:
        return max(1, round(self.time_limit * self.fps))
