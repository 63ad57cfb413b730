"""The interface every LGMD model shares: parameters, frame handling, streams and batches.

A model is streaming: ``step(frame)`` takes one frame and returns one `LGMDOutput`, with
all temporal state (previous frame, delayed inhibition, adaptation...) kept inside. The
same model runs N independent streams at once when built with ``n_streams=N``: then
``step`` takes frames of shape (N, H, W) or (N, H, W, 3) and returns arrays of N values,
identical to N separate streaming models.

A model is a subclass of `LGMDModel`, whose docstring is the contract (the guide to
writing one: docs/guides/own-detector.md). Ego-motion compensation: a model built with
``stabilize="image"`` (or "pose" / "imu", given ``step(frame, rotation=...)``) or
``gain=True`` has a front end (`lgmd_sim.models.stabilize`) that gives the camera's
motion between frames, one without may be given it (``step(frame, motion=Motion(H))``);
every stored map is then warped into the current frame first
(`lgmd_sim.models.compensation`).
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from lgmd_sim.core.frames import to_grey
from lgmd_sim.core.params import CheckedParams, in_range, int_in_range, one_of, param
from lgmd_sim.models.compensation import Compensation
from lgmd_sim.models.guard import PluginError, is_plugin, potentials_fault, run_hook
from lgmd_sim.models.search import SearchRange
from lgmd_sim.models.warp import Motion
from lgmd_sim.signals.metrics import AlarmRule

#: Values of the ``stabilize`` parameter: where each frame's camera rotation comes from.
FRONT_ENDS = ("none", "pose", "imu", "image")


# --- parameters -------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelParams(CheckedParams):
    """Base of every model's parameters: named, defaulted with a source, checked on creation."""

    threshold: float = param(
        0.8,
        "paper Sec. 4.1.3 (Eq. 23): membrane-potential threshold 0.8",
        check=in_range(0.5, 1.0),
        doc="alarm when the membrane potential exceeds this",
    )
    stabilize: str = param(
        "none",
        "our choice: off, as in the paper, which compensates no ego-motion "
        "(docs/reference/models.md, 'Ego-motion compensation (front ends)')",
        check=one_of(*FRONT_ENDS),
        doc="ego-motion compensation: every stored map is warped by the camera's rotation "
            "between frames before the frame goes in; 'pose' / 'imu': the rotation given "
            "to step(rotation=...) (the environments' info['pose_rotation'] / "
            "info['imu_rotation']), 'image': fitted from the frames alone; 'none': off",
    )
    fovy: float = param(
        55.0,
        "the jitter world's camera (lgmd_sim.world.params, fovy)",
        check=in_range(1.0, 179.0),
        doc="vertical field of view (degrees), for the camera intrinsics of 'stabilize'",
    )
    gain: bool = param(
        False,
        "our choice: off, as in the paper (docs/reference/models.md, 'Ego-motion "
        "compensation (front ends)'; measured: docs/experiments/models-log.md, 'Brightness')",
        check=one_of(True, False),
        doc="compensate global brightness changes (auto-exposure, shade, flicker): the "
            "previous frame is scaled by the gain fitted between it and this frame",
    )
    alarm_frames: int = param(
        1,
        "paper Eq. 23: an alarm is a potential above the threshold; the published LGMD1 "
        "code asks 5 consecutive spiking frames, the Colias robot's LGMD 4 "
        "(docs/reference/models.md, 'Footage from any camera')",
        check=int_in_range(1, 30),
        doc="an alarm needs the membrane potential above the threshold in this many "
            "consecutive frames: a shake's one-frame surges then raise none",
    )
    alarm_rising: bool = param(
        False,
        "ours (docs/reference/models.md, 'Footage from any camera'): a looming object's "
        "response climbs to the collision, a motion's onset transient and a shake's surge "
        "fall back",
        check=one_of(True, False),
        doc="an alarm also needs the membrane potential never to fall within those "
            "alarm_frames frames",
    )
    working_height: int = param(
        0,
        "our choice: off, as in the paper (each frame at its own size); the video presets "
        "set their calibration's clip height (docs/reference/models.md, 'Footage from any "
        "camera')",
        check=int_in_range(0, 3840),
        doc="frames taller than this many rows are shrunk to it (area average, the width "
            "in proportion) before the front end and the model see them: the model's "
            "kernels are in pixels, so a preset calibrated on small clips then sees a large "
            "video as it saw its clips; 0: every frame at its own size",
    )


#: The base's parameters a model's ``Params`` must not declare again: the base reads them
#: (the front ends, the alarm rule, the working size), so another meaning or type under
#: their names would silently turn those on or break them. ``threshold`` a model may
#: redeclare, with its own check, for potentials in another range.
RESERVED_PARAMETERS = tuple(f.name for f in dataclasses.fields(ModelParams)
                            if f.name != "threshold")


def reserved_fault(params: type[ModelParams]) -> str | None:
    """Which reserved parameter (`RESERVED_PARAMETERS`) the class `params` declares again,
    as a message; None if none."""
    base = ModelParams.__dataclass_fields__
    taken = [n for n in RESERVED_PARAMETERS if params.__dataclass_fields__.get(n) is not base[n]]
    if not taken:
        return None
    return (f"parameter {taken[0]} is the base class's (ModelParams: "
            f"{base[taken[0]].metadata.get('doc', '').split(':')[0]}) and must not be "
            f"declared again: rename yours; the base's names are {', '.join(base)} "
            "(only threshold may be redeclared, with its own check)")


# --- outputs ----------------------------------------------------------------------------


@dataclass(frozen=True)
class LGMDOutput:
    """One step's result: a float and a bool for a single stream, arrays of N for a batch.

    ``layers`` maps layer names (e.g. "P", "S", "D", "Phi") to maps of shape (H, W), or
    (N, H, W) for a batch; it is None unless ``step(..., layers=True)`` asked for it.
    """

    potential: float | np.ndarray
    alarm: bool | np.ndarray
    layers: Mapping[str, np.ndarray] | None = None


@dataclass(frozen=True)
class StateMap:
    """A stored map of a model's state that moves with the camera (see `state_maps`).

    Attributes:
        attr: the model attribute holding it, an array of shape (N, ..., H, W) (or of
            padded rows, see ``padded``).
        fill: what pixels the warp uncovers get: "frame", the current frame (for the
            previous frame, so that P = 0 there; the brightness gain scales it), or
            "zero".
        padded: None, or the kernel border rule (`lgmd_sim.models.kernels.BORDERS`) of an
            array whose rows hold the image at columns 1..W with one padding column each
            side (and maybe more rows after row H-1): the padding is refilled by that rule.
    """

    attr: str
    fill: str = "zero"
    padded: int | None = None


# --- models -----------------------------------------------------------------------------


class LGMDModel(ABC):
    """A looming detector: streaming, or N independent streams at once.

    Frames are grey (H, W) or RGB colour (H, W, 3), uint8 in 0..255 or float in 0..1;
    batched models take the same with a leading stream axis. The frame size is set by the
    first frame after construction or a full `reset` and must then stay the same.

    **The contract** (in full, with what each part is for: docs/guides/own-detector.md).
    A model (a built-in, or yours: `lgmd_sim.models.register`) declares as class attributes:

    - ``name``; ``Params``, a frozen `ModelParams` subclass, every field a
      `lgmd_sim.core.params.param`, that does not declare the `RESERVED_PARAMETERS` again
      (``threshold``, for potentials in 0.5..1, it may redeclare with its own check);
    - ``layer_names`` (() for none); ``presets``, named overrides of the defaults, the
      first the default preset; ``search_space`` (optional, for ``lgmd-sim calibrate``):
      a `SearchRange` per parameter, or per element of a tuple parameter ("eta[0]");

    and implements the hooks, each on all N streams at once, on arrays it keeps itself:

    - ``allocate(n, height, width)``: the state of n streams (`reset_streams` of every
      stream follows at once);
    - ``reset_streams(idx)``: the streams ``idx`` as new ones, and no others;
    - ``step_batch(grey, layers)``: a read-only C-contiguous (N, H, W) stack, uint8 in
      0..255 or float32 in 0..255 (copy what you keep), to a new float array of the N
      finite potentials, filling every float32 (N, H, W) array of ``layers`` when given;
    - ``state_maps()`` (for the front ends; without it a model runs without them): a
      `StateMap` for every stored map that moves with the camera, warped in place (the
      hooks read the maps through ``self``: a previous frame is made float32 anew);
    - ``maps_moved()`` (optional): after a warp, refresh what is derived from the maps.

    The base gives `step` and `reset` for one stream or N, the checks on every input,
    a plug-in's guards (`lgmd_sim.models.guard`), colour to grey, the front ends and
    ``motion=`` (`lgmd_sim.models.compensation`), the alarms (``potential > threshold`` by
    the `lgmd_sim.signals.metrics.AlarmRule` of ``alarm_frames`` and ``alarm_rising``) and,
    through `lgmd_sim.models.make`, the presets and the parameter checks.
    """

    name: ClassVar[str]
    Params: ClassVar[type[ModelParams]]
    #: Names of the maps `step(..., layers=True)` returns, in the model's order.
    layer_names: ClassVar[tuple[str, ...]]
    #: Named parameter sets; the first is the default.
    presets: ClassVar[Mapping[str, Mapping[str, Any]]] = {"default": {}}
    #: What the calibration searches, by parameter (or "param[i]" of a tuple parameter).
    search_space: ClassVar[Mapping[str, SearchRange]] = {}

    def __init__(self, params: ModelParams | None = None, *, n_streams: int | None = None):
        if n_streams is not None and (
            not isinstance(n_streams, int | np.integer) or isinstance(n_streams, bool)
            or n_streams < 1
        ):
            raise ValueError(f"n_streams must be a positive integer or None, got {n_streams!r}")
        fault = reserved_fault(self.Params)
        if fault:
            raise PluginError(type(self), "Params", fault)
        self.params = params if params is not None else self.Params()
        if not isinstance(self.params, self.Params):
            raise TypeError(f"{self.name} expects {self.Params.__name__}, got {type(params)}")
        self.n_streams = n_streams
        self._n = 1 if n_streams is None else int(n_streams)
        self.frame_shape: tuple[int, int] | None = None
        #: The ego-motion front end (`lgmd_sim.models.stabilize`), None without one.
        self.front_end = None
        if self.params.stabilize != "none" or self.params.gain:
            if not self.has_state_maps():
                raise ValueError(f"{self.name} lists no state maps (state_maps), so it runs "
                                 "without front ends only: stabilize 'none', gain off")
            from lgmd_sim.models.stabilize import FrontEnd

            self.front_end = FrontEnd(self.params, self._n)
        self._compensation = Compensation()
        self.alarm_rule = AlarmRule(self.params.alarm_frames, self.params.alarm_rising)
        # a plug-in's potentials are checked every step, as check_model checks them once
        self._plugin = is_plugin(type(self))
        self._threshold_check = type(self.params).__dataclass_fields__["threshold"].metadata[
            "check"]
        #: Per stream, the potentials of the last ``alarm_frames`` frames, oldest first
        #: (-inf before a stream's first).
        self._recent = np.full((self._n, self.params.alarm_frames), -np.inf)

    @property
    def batched(self) -> bool:
        return self.n_streams is not None

    def reset(self, streams: Sequence[int] | np.ndarray | None = None) -> None:
        """Start new streams: all of them (the frame size may then change), or those listed."""
        if streams is None:
            self.frame_shape = None
            self._recent[:] = -np.inf
            if self.front_end is not None:
                self.front_end.reset(None)
            return
        if not self.batched:
            raise ValueError("reset(streams=...) needs a batched model (n_streams=N)")
        idx = np.asarray(streams).reshape(-1)
        if idx.size and not np.issubdtype(idx.dtype, np.integer):  # 0.7 or True is no index
            raise ValueError(f"stream indices must be integers, got {np.asarray(streams)!r}")
        idx = idx.astype(np.intp)
        if idx.size and (idx.min() < 0 or idx.max() >= self._n):
            raise ValueError(f"stream index out of range 0..{self._n - 1}: {idx.tolist()}")
        self._recent[idx] = -np.inf
        if self.frame_shape is not None and idx.size:
            run_hook(type(self), "reset_streams", self.reset_streams, idx)
        if self.front_end is not None and idx.size:
            self.front_end.reset(idx)

    def step(self, frame: np.ndarray, *, layers: bool = False, motion: Motion | None = None,
             rotation: np.ndarray | None = None) -> LGMDOutput:
        """Feed one frame (one per stream when batched); return potentials and alarms.

        Args:
            frame: the frame, (H, W) or (H, W, 3); (N, H, W) or (N, H, W, 3) when batched.
            layers: also return the layer maps (``out.layers``; at the size the model
                works at, see ``working_height``).
            motion: the camera's motion since the previous frame (`Motion`: homography
                and brightness gain): every stored map is warped by it first. Only for a
                model without a front end (``stabilize="none"``, ``gain=False``).
            rotation: for ``stabilize="pose"`` or ``"imu"``: the camera's rotation since
                the previous frame, a rotation vector (rad, camera frame: x right, y up,
                z backwards), (3,) or (N, 3); the environments' ``info["pose_rotation"]``
                or ``info["imu_rotation"]`` (see `rotation_key`).
        """
        grey = self._shrink(self._to_grey_stack(frame))
        # It may be the caller's frame, which every other model of a run reads too: no
        # model may write into it (a read-only view costs no copy).
        grey = grey.view()
        grey.flags.writeable = False
        if self.front_end is not None:
            if motion is not None:
                raise ValueError(f"{self.name}: estimates its own motion (stabilize="
                                 f"{self.params.stabilize!r}, gain={self.params.gain}); "
                                 "motion= is for models without a front end")
            motion = self.front_end.motion(grey, rotation)
        elif rotation is not None:
            raise ValueError(f"{self.name}: rotation= needs stabilize='pose' or 'imu'")
        elif motion is not None and not self.has_state_maps():
            raise ValueError(f"{self.name} lists no state maps (state_maps), so it takes no "
                             "motion=")
        hs, gains, horizons, grounds = (None,) * 4 if motion is None else motion.per_stream(
            self._n)
        shape = (grey.shape[1], grey.shape[2])
        if self.frame_shape is None:
            self.frame_shape = shape
            run_hook(type(self), "allocate", self.allocate, self._n, *shape)
            run_hook(type(self), "reset_streams", self.reset_streams, np.arange(self._n))
        elif shape != self.frame_shape:
            raise ValueError(
                f"{self.name}: frame size {shape[0]}x{shape[1]} differs from this stream's "
                f"{self.frame_shape[0]}x{self.frame_shape[1]}; call reset() to start a new stream"
            )
        elif hs is not None or gains is not None:
            self._compensation.warp(self, grey, hs, gains, horizons, grounds)
        maps = {n: np.empty((self._n, *shape), np.float32) for n in self.layer_names} if (
            layers
        ) else None
        potential = run_hook(type(self), "step_batch", self.step_batch, grey, maps)
        if self._plugin:
            fault = potentials_fault(potential, self._n, self._threshold_check)
            if fault:
                raise PluginError(type(self), "potentials", fault)
        self._recent[:, :-1] = self._recent[:, 1:]  # in place: every step of every model
        self._recent[:, -1] = potential
        alarm = self.alarm_rule.levels(self._recent) > self.params.threshold
        if self.batched:
            return LGMDOutput(potential, alarm, maps)
        one = {k: v[0] for k, v in maps.items()} if maps is not None else None
        return LGMDOutput(float(potential[0]), bool(alarm[0]), one)

    @property
    def rotation_key(self) -> str | None:
        """The ``info`` key whose value `step` needs as ``rotation`` each frame
        ("pose_rotation" or "imu_rotation"), or None: the frames are enough."""
        return {"pose": "pose_rotation", "imu": "imu_rotation"}.get(self.params.stabilize)

    def rotation_from(self, info: Mapping[str, Any] | Sequence[Mapping[str, Any]]
                      ) -> np.ndarray | None:
        """The ``rotation`` `step` needs, from an environment step's ``info`` (for a
        batch, a sequence of infos, one per stream); None when the frames are enough."""
        key = self.rotation_key
        if key is None:
            return None
        if isinstance(info, Mapping):
            return info[key]
        return np.stack([i[key] for i in info])

    # -- hooks -------------------------------------------------------------------------

    @classmethod
    def has_state_maps(cls) -> bool:
        """Whether the class lists its state maps (`state_maps`), so that it can be
        motion-compensated; without them it runs without front ends only."""
        return cls.state_maps is not LGMDModel.state_maps

    def state_maps(self) -> Sequence[StateMap]:
        """The stored maps (each an attribute of shape (N, ..., H, W)) that move with the
        camera, for ego-motion compensation; a model without the list cannot be warped
        (see the class's contract)."""
        raise NotImplementedError(f"{self.name}: {type(self).__name__} lists no state maps, "
                                  "so it cannot be motion-compensated")

    def maps_moved(self) -> None:  # noqa: B027  (optional hook)
        """After `state_maps` were warped: refresh what is derived from them."""

    @abstractmethod
    def allocate(self, n: int, height: int, width: int) -> None:
        """Allocate the state of n streams of height x width frames (values need not be
        set: `reset_streams` of every stream follows)."""

    @abstractmethod
    def reset_streams(self, idx: np.ndarray) -> None:
        """Give the streams in idx (an int array) the state of a new stream (no previous
        frame)."""

    @abstractmethod
    def step_batch(self, grey: np.ndarray, layers: dict[str, np.ndarray] | None) -> np.ndarray:
        """Process grey frames (N, H, W), uint8 in 0..255 or float32 in 0..255; return the
        N potentials, a new float array.

        When ``layers`` is given, fill each of its float32 (N, H, W) arrays with that
        layer's map.
        """

    # -- frames ------------------------------------------------------------------------

    def _shrink(self, grey: np.ndarray) -> np.ndarray:
        """Frames (N, H, W) at most ``working_height`` rows tall (the same dtype)."""
        h = self.params.working_height
        if not h or grey.shape[1] <= h:
            return grey
        import cv2

        size = (max(1, round(grey.shape[2] * h / grey.shape[1])), h)
        return np.stack([cv2.resize(f, size, interpolation=cv2.INTER_AREA) for f in grey])

    def _to_grey_stack(self, frame: np.ndarray) -> np.ndarray:
        """Frames as a C-contiguous (N, H, W) uint8 or float32 (0..255) stack."""
        a = np.asarray(frame)
        lead = 1 if self.batched else 0
        what = "(N, H, W) or (N, H, W, 3)" if self.batched else "(H, W) or (H, W, 3)"
        if a.ndim == lead + 3 and a.shape[-1] == 1:
            a = a[..., 0]
        colour = a.ndim == lead + 3 and a.shape[-1] == 3
        if not (a.ndim == lead + 2 or colour):
            raise ValueError(f"{self.name}: expected frames of shape {what}, got {a.shape}")
        if self.batched and a.shape[0] != self._n:
            raise ValueError(
                f"{self.name}: expected {self._n} frames (one per stream), got {a.shape[0]}"
            )
        if min(a.shape[lead : lead + 2]) < 1:
            raise ValueError(f"{self.name}: empty frame of shape {a.shape}")
        if a.dtype == np.uint8:
            pass
        elif np.issubdtype(a.dtype, np.floating):
            if not np.isfinite(a).all():
                raise ValueError(f"{self.name}: frame contains NaN or infinite values")
            lo, hi = float(a.min()), float(a.max())
            if lo < 0.0 or hi > 1.0:
                raise ValueError(
                    f"{self.name}: float frames must lie in [0, 1], got values in [{lo:g}, {hi:g}]"
                    " (pass uint8 for 0..255 images)"
                )
            a = a.astype(np.float32) * np.float32(255.0)
        else:
            raise ValueError(f"{self.name}: frames must be uint8 or float, got {a.dtype}")
        if not self.batched:
            a = a[None]
        if colour:
            a = np.stack([to_grey(f) for f in a])
        return np.ascontiguousarray(a)
