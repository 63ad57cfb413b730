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


class JitterEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """A camera carrier (robot, hand-held or tripod camera) among obstacles.

    One step is one camera frame (1/fps s of physics).

    - Observation: a Dict of ``frame`` (uint8 (H, W, 3) RGB or (H, W, 1) grey; no
      ``frame`` key when ``frame="none"``: nothing is rendered, for policies that read
      the ground truth),
      ``proprio`` (float32 (11,): left and right wheel speeds in rad/s, 0 for carriers
      without wheels; IMU angular velocity in rad/s and specific force in m/s^2, in the
      carrier's frame; the IMU's rotation of the camera over the last frame interval,
      ``info["imu_rotation"]``) and, when the scenario has a goal, ``goal`` (float32:
      distance in m, sine and cosine of its bearing from the camera's heading, positive
      to the left).
    - Action: Box [-1, 1]^2, scaled to (linear velocity, angular velocity) by
      ``max_speed`` and ``max_turn``; values outside are clipped; NaN, infinite or
      complex values raise ValueError. A tripod ignores the action.
    - Reward: ``progress_reward`` per metre of progress towards the goal, minus
      ``collision_penalty`` on a step with a collision, minus ``effort_penalty`` times the
      squared action norm (``info["task_reward"]``, the task's own reward); plus the
      shaping options, all 0 by default: ``goal_bonus`` on the step the goal is reached,
      minus ``time_penalty`` per second, minus ``proximity_penalty`` per second while the
      threat is in the Oracle's trigger zone (`lgmd_sim.envs.zone`).
    - Terminated on a collision (if ``terminate_on_collision``) or on reaching the goal;
      truncated after ``time_limit * fps`` steps. A step after either, without a reset,
      raises ``gymnasium.error.ResetNeeded`` (Gymnasium's `OrderEnforcing` only checks
      the first step).
    - ``info``: the ground truth of the frame (see `JitterWorld`): time, frame_index, carrier
      and camera pose, camera angular and linear velocity (camera frame: x right, y up,
      z backwards), the camera's rotation since the previous frame (rotation vectors in
      the previous camera frame, rad; zero on the reset frame) from its poses,
      ``pose_rotation``, and from its IMU, ``imu_rotation`` (the camera's angular velocity
      integrated over the frame's physics steps, with ``gyro_noise`` and ``gyro_bias``),
      the most threatening obstacle's (or arena wall's; one touched in the frame first)
      index, distance, bearing, closing speed and time to collision, collision flag and
      first collision frame, with ``ssim=True`` ``ssim`` (the SSIM with the previous
      frame; NaN on the reset frame and when ``frame="none"``), goal distance and bearing,
      ``task_reward`` (on steps), ``goal_reached`` and its alias
      ``is_success`` (the key stable-baselines3 logs as the success rate).

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
