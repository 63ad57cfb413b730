"""`JitterEnv`: the Gymnasium environment over a `JitterWorld`."""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from lgmd_sim.envs.catalogue import params_for
from lgmd_sim.envs.params import EnvParams
from lgmd_sim.envs.zone import TriggerZone, in_trigger_zone
from lgmd_sim.world.core import PROPRIO_RANGE, JitterWorld

#: Observation bound of the goal distance (m).
GOAL_RANGE = 1000.0
#: Where ``proximity_penalty`` applies: the Oracle's trigger zone.
PROXIMITY_ZONE = TriggerZone()
#: What each key of the observation holds.
OBSERVATION_KEYS: dict[str, str] = {
    "frame": "the camera frame: uint8 RGB (H, W, 3), or grey (H, W, 1) with frame=\"grey\"",
    "proprio": "proprioception, float32 (11,): left and right wheel speeds (rad/s; 0 for "
               "carriers without wheels), the IMU's angular velocity (rad/s) and specific "
               "force (m/s^2) in the carrier's frame, and its rotation of the camera over "
               "the last frame interval (rad, info[\"imu_rotation\"])",
    "goal": f"the goal, float32 (3,): distance (m, at most {GOAL_RANGE:g}), sine and cosine "
            "of its bearing from the camera's heading (positive to the left)",
}
#: What each key of ``info`` holds besides the ground truth of the frame.
INFO_KEYS: dict[str, str] = {
    "task_reward": "the task's own reward of the step, without the shaping options (on "
                   "steps, not on reset)",
    "goal_reached": "the goal is reached on this step",
    "is_success": "goal_reached, under the name stable-baselines3 logs as the success rate",
}


class JitterEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """A camera carrier (robot, hand-held or tripod camera) among obstacles.

    One step is one camera frame (1/fps s of physics).

    - Observation: a Dict of the keys of `OBSERVATION_KEYS`: ``frame`` (none when
      ``frame="none"``: nothing is rendered, for policies that read the ground truth),
      ``proprio``, and ``goal`` when the scenario has a goal.
    - Action: Box [-1, 1]^2, scaled to (linear velocity, angular velocity) by
      ``max_speed`` and ``max_turn``; values outside are clipped; NaN, infinite or
      complex values raise ValueError. A tripod ignores the action.
    - Reward: ``progress_reward`` per metre of progress towards the goal, minus
      ``collision_penalty`` on a step with a collision, minus ``effort_penalty`` times the
      squared action norm (``info["task_reward"]``, the task's own reward); plus the
      shaping options, all 0 by default: ``goal_bonus`` on the step the goal is reached,
      minus ``time_penalty`` per second, minus ``proximity_penalty`` per second while the
      threat is in the Oracle's trigger zone (`lgmd_sim.envs.zone`).
    - Episode end: terminated on a collision (if ``terminate_on_collision``) or on
      reaching the goal (within ``goal_radius``); truncated after ``time_limit * fps``
      steps. A step after either, without a reset, raises ``gymnasium.error.ResetNeeded``
      (Gymnasium's `OrderEnforcing` only checks the first step).
    - Info: the ground truth of the frame (`lgmd_sim.world.core.TRUTH_KEYS`, see
      `JitterWorld`) and the keys of `INFO_KEYS`.

    The scenario reference (docs/reference/scenarios.md, ``python -m scripts.reference``) is made
    from these items, `OBSERVATION_KEYS`, `INFO_KEYS` and `TRUTH_KEYS`.

    Args:
        scenario: a catalogue scenario name (envs/<name>.toml) or None for the defaults.
        render_mode: None or "rgb_array" (the camera view, rendered on demand when
            ``frame="none"``; the chase view when ``render_camera="chase"``).
        ssim: put each frame's SSIM with the previous one in ``info["ssim"]``. Off unless
            asked: it costs about a twentieth of a frame's render, and only datasets and
            the demo read it.
        **overrides: any parameter of `EnvParams` (see ``lgmd-sim envs <name>``).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, scenario: str | None = None, render_mode: str | None = None, *,
                 ssim: bool = False, **overrides: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.params: EnvParams = params_for(scenario, overrides)
        self.scenario = scenario
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": self.params.fps}
        self.world = JitterWorld(self.params, ssim=ssim)
        h, w = self.params.size
        obs: dict[str, spaces.Space] = {}
        if self.params.frame != "none":
            channels = 3 if self.params.frame == "rgb" else 1
            obs["frame"] = spaces.Box(0, 255, (h, w, channels), np.uint8)
        obs["proprio"] = spaces.Box(-PROPRIO_RANGE.astype(np.float32),
                                    PROPRIO_RANGE.astype(np.float32), dtype=np.float32)
        self._has_goal = self.params.goal_distance > 0
        if self._has_goal:
            obs["goal"] = spaces.Box(np.array([0, -1, -1], np.float32),
                                     np.array([GOAL_RANGE, 1, 1], np.float32), dtype=np.float32)
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._scale = np.array([self.params.max_speed, self.params.max_turn])
        self._steps = 0
        self._goal_distance = 0.0
        self._needs_reset = True
        self._closed = False

    # -- Gymnasium API -------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self._check_open()
        if options:
            raise ValueError(f"unknown reset option(s) {', '.join(map(repr, options))}: "
                             "JitterEnv.reset takes none")
        super().reset(seed=seed)
        # The episode's world seed comes from the env's generator: reset(seed=s) fixes
        # every later episode too, as Gymnasium specifies.
        self.world.reset(seed=int(self.np_random.integers(2**63)))
        self._steps = 0
        self._goal_distance = self.world.truth.get("goal_distance", 0.0)
        self._needs_reset = False
        return self._observation(), {**self.world.truth, "goal_reached": False,
                                     "is_success": False}

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool,
                                                 dict[str, Any]]:
        self._check_open()
        if self._needs_reset:
            raise gym.error.ResetNeeded("call reset() before step()" if self._steps == 0 else
                                        "the episode has ended (terminated or truncated): "
                                        "call reset() before step()")
        a = np.asarray(action)
        if a.shape != (2,):
            raise ValueError(f"action must have shape (2,), got {a.shape}")
        if np.iscomplexobj(a):  # casting would drop the imaginary part silently
            raise ValueError(f"action must be real, got {a.tolist()}")
        a = a.astype(np.float64)
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite, got {a.tolist()}")
        a = np.clip(a, -1.0, 1.0)
        v, omega = a * self._scale
        self.world.step(float(v), float(omega))
        self._steps += 1
        p, truth = self.params, self.world.truth
        reward = -p.effort_penalty * float(a @ a)
        if truth["collision"]:
            reward -= p.collision_penalty
        reached = False
        if self._has_goal:
            reward += p.progress_reward * (self._goal_distance - truth["goal_distance"])
            self._goal_distance = truth["goal_distance"]
            reached = truth["goal_distance"] < p.goal_radius
        task_reward = reward
        if reached:
            reward += p.goal_bonus
        penalty = p.time_penalty
        if p.proximity_penalty and in_trigger_zone(truth, PROXIMITY_ZONE):
            penalty += p.proximity_penalty
        reward -= penalty / p.fps  # per second: one step is one frame
        terminated = reached or (p.terminate_on_collision and truth["collision"])
        truncated = not terminated and self._steps >= p.max_steps
        self._needs_reset = terminated or truncated
        info = {**truth, "task_reward": task_reward, "goal_reached": reached,
                "is_success": reached}
        return self._observation(), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        self._check_open()
        if self.render_mode != "rgb_array":
            return None
        if self.params.render_camera == "chase":
            return self.world.render_chase()
        if self.params.frame == "none":  # nothing rendered on the step: render now
            return self.world.render_camera()
        return self.world.rgb.copy()

    def close(self) -> None:
        self.world.close()
        self._closed = True

    # -- helpers -------------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise gym.error.ClosedEnvironmentError("the environment is closed")

    def _observation(self) -> dict[str, np.ndarray]:
        w = self.world
        obs: dict[str, np.ndarray] = {}
        # The world makes fresh frame arrays every step: no copy needed.
        if self.params.frame == "rgb":
            obs["frame"] = w.rgb
        elif self.params.frame == "grey":
            obs["frame"] = w.grey[:, :, None]
        obs["proprio"] = w.proprio()
        if self._has_goal:
            bearing = w.truth["goal_bearing"]
            obs["goal"] = np.array([min(w.truth["goal_distance"], GOAL_RANGE), np.sin(bearing),
                                    np.cos(bearing)], np.float32)
        return obs
