"""Parameters of a jitter environment: the world's (`SceneParams`) plus task and reward."""

from __future__ import annotations

from dataclasses import dataclass

from lgmd_sim.params import in_range, non_negative, one_of, param
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
    terminate_on_collision: bool = param(True, DESIGN, check=one_of(True, False),
                                         doc="end the episode at the first collision")

    @property
    def max_steps(self) -> int:
        return max(1, round(self.time_limit * self.fps))
