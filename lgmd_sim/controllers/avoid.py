"""Avoidance controllers: cruise to the goal; when triggered, brake and turn away for a
set time, then resume. `ReactiveAvoid` is triggered by an LGMD model's alarm, `Oracle` by
the ground truth, `ViewOracle` by the ground truth of what the camera sees; all share the
manoeuvre, so they differ only in what triggers it."""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from lgmd_sim import models
from lgmd_sim.controllers.base import Controller
from lgmd_sim.controllers.detector import DetectorParams, eye_overlap, eyes
from lgmd_sim.controllers.straight import StraightParams
from lgmd_sim.core.params import in_range, one_of, param
from lgmd_sim.envs.wrappers.frames import check_frame_space
from lgmd_sim.envs.zone import CRUISE, ORACLE_TUNED, TriggerZone, in_trigger_zone
from lgmd_sim.models.layers import needed_layer
from lgmd_sim.models.sectors import Sectors

__all__ = [
    "AvoidParams",
    "Avoider",
    "Oracle",
    "OracleParams",
    "ReactiveAvoid",
    "ReactiveParams",
    "ViewOracle",
    "ViewTruth",
]


@dataclass(frozen=True)
class AvoidParams(StraightParams):
    """The cruise of `Straight` and the avoidance manoeuvre."""

    cruise: float = param(CRUISE, ORACLE_TUNED, check=in_range(-1.0, 1.0),
                          doc="forward action while cruising (fraction of max_speed)")
    avoid_time: float = param(0.7, ORACLE_TUNED, check=in_range(0.0, 10.0),
                              doc="duration of the manoeuvre (s)")
    avoid_speed: float = param(-0.1, ORACLE_TUNED, check=in_range(-1.0, 1.0),
                               doc="forward action during the manoeuvre (brake: near 0; "
                                   "backing off a little keeps the turning chassis clear)")
    avoid_turn: float = param(1.0, ORACLE_TUNED, check=in_range(0.0, 1.0),
                              doc="turn action during the manoeuvre, away from the threat")
    pass_time: float = param(0.8, ORACLE_TUNED, check=in_range(0.0, 10.0),
                             doc="after the turn, drive straight on at cruise for this long "
                                 "(s) before heading for the goal again: past the obstacle, "
                                 "not back into it")
    refractory: float = param(0.3, ORACLE_TUNED, check=in_range(0.0, 10.0),
                              doc="time after a manoeuvre during which triggers are ignored "
                                  "(s): the turn itself sweeps the view")


class Avoider(Controller):
    """Cruise towards the goal (as `Straight`); on a trigger, turn away from the side the
    trigger names for ``avoid_time`` seconds at ``avoid_speed``, then resume. Reads
    ``info["time"]`` and ``info["goal_bearing"]``; subclasses read their trigger."""

    params: AvoidParams

    def reset(self) -> None:
        self._until = -math.inf  # end of the current manoeuvre (s)
        self._turn = 0.0
        self.alarm = False
        self.manoeuvring = False

    def act(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> np.ndarray:
        p, now = self.params, float(info["time"])
        side = self._trigger(obs, info)  # every frame: models must see them all
        self.alarm = side is not None
        if side is not None and now >= self._until + p.refractory:
            self._until = now + p.avoid_time
            self._turn = -p.avoid_turn if side > 0 else p.avoid_turn  # away from the threat
        self.manoeuvring = now < self._until
        if self.manoeuvring:  # braking and turning away
            return np.array([p.avoid_speed, self._turn], np.float32)
        if now < self._until + p.pass_time:  # driving on, past the obstacle
            return np.array([p.cruise, 0.0], np.float32)
        turn = float(np.clip(p.heading_gain * info.get("goal_bearing", 0.0), -1.0, 1.0))
        return np.array([p.cruise, turn], np.float32)

    @abstractmethod
    def _trigger(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> float | None:
        """None, or the side of the threat: > 0 on the left, <= 0 on the right."""


@dataclass(frozen=True)
class OracleParams(TriggerZone, AvoidParams):
    """The manoeuvre's constants and the trigger zone (`lgmd_sim.envs.zone.TriggerZone`:
    the benchmark's encounters and the environment's proximity penalty are the same)."""


class Oracle(Avoider):
    """The manoeuvre triggered by ground truth: the threat in the trigger zone
    (`in_trigger_zone`), turning away from its bearing. The upper bound of what the
    manoeuvre can do, and the check that it can avoid the obstacles at all."""

    Params = OracleParams
    params: OracleParams

    def _trigger(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> float | None:
        return float(info["threat_bearing"]) if in_trigger_zone(info, self.params) else None


class ViewTruth(gym.Wrapper):
    """`env` with the ground truth of what its camera sees: after each reset and step,
    ``info`` gains the keys of `lgmd_sim.world.view.VIEW_KEYS`, the most threatening of
    the threats the camera sees (`lgmd_sim.world.view.CameraView`), read from the world
    of ``env.unwrapped`` (a `JitterEnv`). Only the controllers that read them wrap an
    environment in it: the rays cost a fraction of a frame's render."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        world = getattr(env.unwrapped, "world", None)
        if world is None:
            raise TypeError(f"ViewTruth needs a JitterEnv (its world), got {env.unwrapped!r}")
        from lgmd_sim.world.view import CameraView

        self._view = CameraView(world)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._view.new_episode()
        return obs, self._with_view(info)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        return obs, reward, terminated, truncated, self._with_view(info)

    def _with_view(self, info: dict[str, Any]) -> dict[str, Any]:
        return {**info, **self._view.threat(info)}


class ViewOracle(Oracle):
    """The Oracle's manoeuvre and trigger zone, triggered by the ground truth of what the
    camera sees: the most threatening of the threats in view and not hidden, in the
    trigger zone (`in_trigger_zone` of ``info["view_threat_ttc"]``,
    ``["view_threat_distance"]`` and ``["view_threat_bearing"]``), turning away from its
    bearing.

    *In view*: some line of sight to it leaves the camera inside the frame's frustum
    (``fovy`` up and down, as wide as the frame's aspect ratio makes it, in front of the
    near clip plane). *Not hidden*: that line of sight meets it before any other obstacle,
    the terrain, the scenery or the goal flag. `lgmd_sim.world.view` defines the lines of
    sight tried; `wrap_env` puts the view keys in ``info`` (`ViewTruth`). Among those seen,
    the threat is ranked as the ground truth's is: one touched first, else the soonest to
    collide, else the nearest; its time to collision is the ground truth's.

    What it is for: a ceiling for a camera-driven controller. The Oracle also reacts to
    obstacles the camera cannot see (beside the robot, behind another); this one reacts
    only to what is in the frame, as an LGMD can at best. An LGMD's gap to the Oracle
    splits into the camera's (the Oracle's gap to this one) and the detector's (this
    one's gap to the LGMD)."""

    def wrap_env(self, env: gym.Env) -> gym.Env:
        return ViewTruth(super().wrap_env(env))

    def _trigger(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> float | None:
        view = {"threat_ttc": info["view_threat_ttc"],
                "threat_distance": info["view_threat_distance"],
                "threat_bearing": info["view_threat_bearing"]}
        return float(view["threat_bearing"]) if in_trigger_zone(view, self.params) else None


@dataclass(frozen=True)
class ReactiveParams(DetectorParams, AvoidParams):
    """The manoeuvre's constants, the detector that triggers it, and how it tells the side."""

    side: str = param("halves", "design: one LGMD, as the published models are",
                      check=one_of("halves", "eyes"),
                      doc="how the threat's side is told: 'halves', one LGMD over the whole "
                          "view and its S layer's left and right halves (a model without an "
                          "S layer: its last layer's); 'eyes', two LGMDs "
                          "over overlapping left and right parts of the view, alarming when "
                          "either does, turning away from the more excited")
    eye_overlap: float = eye_overlap("with side='eyes', the share of the view's width both "
                                     "eyes see")


class ReactiveAvoid(Avoider):
    """The manoeuvre triggered by an LGMD model's alarm (potential above its threshold),
    turning away from the threat's side: with ``side="halves"``, the half of the view
    with more S-layer activity; with ``side="eyes"``, the more excited of two LGMDs over
    overlapping left and right parts of the view (`lgmd_sim.models.sectors.Sectors`),
    either of which alarms. ``potential`` is the last frame's membrane potential (of the
    more excited eye). Reads ``obs["frame"]`` (every frame goes through the model),
    ``info["time"]``, and for a model stabilized by the pose or the IMU (preset
    "...+pose", "...+imu") the camera's rotation in ``info``."""

    Params = ReactiveParams
    params: ReactiveParams
    uses_model = True

    def __init__(self, **params: Any) -> None:
        p = self.Params(**params)  # checked before the model is made from it
        if p.side == "eyes":
            self.model = eyes(p, p.eye_overlap)
        else:
            self.model = models.make(p.model, preset=p.preset, **dict(p.model_params))
            self._side_layer = needed_layer(
                p.model, "ReactiveAvoid side='halves' compares the left and right halves of",
                "use side='eyes'")
        super().__init__(**params)

    def wrap_env(self, env: gym.Env) -> gym.Env:
        # refused before the first step, in one line, rather than a KeyError on obs["frame"]
        check_frame_space(env.observation_space)
        return super().wrap_env(env)

    def reset(self) -> None:
        super().reset()
        self.model.reset()
        self.potential = 0.5

    def _trigger(self, obs: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> float | None:
        # a pose- or IMU-stabilized model reads its rotation from info
        rotation = self.model.rotation_from(info)
        if isinstance(self.model, Sectors):
            out = self.model.step(obs["frame"], rotation=rotation)
            left, right = (float(v) for v in out.potential)
            self.potential = max(left, right)
            return left - right if out.alarm.any() else None  # > 0: more on the left
        out = self.model.step(obs["frame"], layers=True, rotation=rotation)
        self.potential = out.potential
        if not out.alarm:
            return None
        # signed in LGMD1 (E - w I): its activity either way
        s = np.abs(out.layers[self._side_layer])
        half = s.shape[1] // 2
        return float(s[:, :half].mean() - s[:, -half:].mean())  # > 0: more on the left
