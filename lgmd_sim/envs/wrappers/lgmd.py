"""LGMD models watching the camera: potentials, alarms and where the S layer is active.

`LGMDFeatures` computes the LGMD part of the observation of n environments, with one
batched model (n streams) per model name. `LGMDObservation` (one environment),
`LGMDVectorObservation` (a Gymnasium vector environment) and
`lgmd_sim.envs.wrappers.sb3.VecLGMDObservation` (a stable-baselines3 VecEnv) all use it,
so they give the same outputs; only the bookkeeping of resets differs.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv, VectorWrapper
from gymnasium.vector.utils import batch_space

from lgmd_sim import models
from lgmd_sim.core.params import because, checked, count, optional, seed, tuple_of
from lgmd_sim.envs.wrappers.frames import check_frame_space, frame_size_of
from lgmd_sim.models.layers import needed_layer

__all__ = ["KEYS", "MAX_FEATURES", "LGMDFeatures", "LGMDObservation", "LGMDVectorObservation"]

#: The observation keys the LGMD wrappers add.
KEYS = ("lgmd_potential", "lgmd_alarm", "lgmd_grid", "lgmd_memory")
#: The membrane potential of a resting LGMD (a stream's first frame gives it).
REST = 0.5
#: The most values one model's potentials, or its grids, may hold per environment: 2**20
#: (4 MB of float32), a grid of every pixel of a "paper" frame (270 x 480) eight times over.
#: The features are a compact summary for a policy's MLP; a larger request (history=1e9
#: from a policy.json) would exhaust the memory when the wrapper is made, before any use.
MAX_FEATURES = 2**20


def _check_grid(grid: tuple[int, int], height: int, width: int) -> None:
    """Every cell of `grid` must hold a pixel of a `height` x `width` frame."""
    rows, cols = grid
    if rows > height or cols > width:
        raise ValueError(f"grid {rows}x{cols} has more cells than the {height}x{width} "
                         "frame has pixels")


class LGMDFeatures:
    """The LGMD observation of n environments: one batched model (n streams) per model.

    Per model, in the order given, the observation holds (float32, one Box per key, the
    models one after another along the only axis: reshape to (n_models, -1) to split):

    - ``lgmd_potential`` (n_models * history,): the last ``history`` membrane potentials,
      oldest first. At a reset the history is filled with the resting potential 0.5; the
      newest entry is then the first frame's potential (0.5 too: no motion yet).
    - ``lgmd_alarm`` (n_models,): 1.0 where the newest potential is above the model's
      threshold, else 0.0.
    - ``lgmd_grid`` (n_models * rows * cols,), without it when ``grid`` is None: where the
      threat is. The frame is cut into rows x cols cells (row-major: top row first, left
      to right); each cell holds the mean of the rectified S layer ([S]+, the excitation
      on its way to the LGMD cell; a plug-in without one: its last layer, and one without
      layers takes no grid: `lgmd_sim.models.layers`) over its pixels, normalised to sum
      to 1 over the grid:
      the cell's share of the activity (1 / cells each where S is 0 everywhere, as on the
      first frame). Shares rather than raw means because the scale of S differs by orders
      of magnitude between models, presets and frame sizes, while a share is comparable
      and bounded in [0, 1]; how strong the activity is, is the potential's job. With
      ``grid_history`` k > 1 it holds the last k grids, oldest first (k * rows * cols per
      model): where the activity grows, cell by cell; a reset fills them with the first
      frame's.
    - ``lgmd_memory`` (n_models * cols,), with ``memory`` m > 0 frames (needs a grid):
      where, by column, the potential rose lately, for what has left the frame. On each
      frame the column holding the grid's largest share takes the potential's excitation
      (0 at rest, 1 at the model's threshold, clipped to [0, 1]) where that is more than
      it holds; every column loses 1/m a frame. So an alarm is remembered at its bearing
      for m frames, fading; a reset clears it.

    Bounds: potentials and grid in [0, 1] (potentials are sigmoids, mostly [0.5, 1)),
    alarms in {0, 1}. 1-D Boxes, as stable-baselines3's MultiInputPolicy and its
    ``check_env`` want. The full model outputs go to ``info``: ``info["lgmd_potential"]``
    and ``info["lgmd_alarm"]``, each a dict of model name -> float / bool.

    Args:
        n_envs: number of environments (streams of each model).
        model: a name of `lgmd_sim.models.available()` or a plug-in's
            "package.module:Class" spec, or a list of them.
        preset: the models' parameter set (None: each model's default), optionally with
            front ends ("published+image", see `lgmd_sim.models.parse_spec`); with several
            models it, like ``params``, applies to every one of them. A model that
            compensates the camera's rotation from the pose or the IMU (``stabilize="pose"``
            or ``"imu"``) reads it from each step's ``info`` (see `rotation_keys`).
        history: number of membrane potentials observed, newest last.
        grid: (rows, cols) of the S-layer summary, or None for none (and no layer maps
            computed: faster).
        grid_history: number of grids observed, newest last.
        memory: frames the per-column memory of the excitation lasts; 0 for none.
        keep_frame: keep the camera frame in the observation; False drops it, for
            compact observations (MLP policies).
        frame_size: (height, width) of the frames, where known: a grid with more rows or
            columns than a frame has pixels is then refused before anything is allocated
            (else at the first frame).
        **params: the models' parameter overrides (see ``lgmd-sim models NAME``).

    Raises:
        ValueError: a bad argument, naming it; `history`, or `grid_history` grids, of more
            than `MAX_FEATURES` values.
    """

    def __init__(self, n_envs: int, model: str | Sequence[str] = "feedback", *,
                 preset: str | None = None, history: int = 8,
                 grid: tuple[int, int] | None = (1, 3), grid_history: int = 1,
                 memory: int = 0, keep_frame: bool = True,
                 frame_size: tuple[int, int] | None = None, **params: Any) -> None:
        checked("n_envs", n_envs, count)
        names = [model] if isinstance(model, str) else model
        if not (isinstance(names, Sequence) and names and all(isinstance(n, str) for n in names)):
            raise ValueError(f"model must be a model name or a list of them, got {model!r}")
        if len(set(names)) < len(names):
            raise ValueError(f"model names a model twice: {list(names)}")
        checked("history", history, count)
        checked("grid_history", grid_history, count)
        checked("grid", grid, optional(because(tuple_of(count, 2), "(rows, cols)")))
        checked("memory", memory, seed)
        if memory and grid is None:
            raise ValueError("memory needs a grid: it remembers by the grid's columns")
        if not isinstance(keep_frame, bool | np.bool_):
            raise ValueError(f"keep_frame must be True or False, got {keep_frame!r}")
        self.grid = None if grid is None else (int(grid[0]), int(grid[1]))
        cells = 0 if self.grid is None else self.grid[0] * self.grid[1]
        # sizes checked before anything of those sizes is allocated, models included
        if history > MAX_FEATURES:
            raise ValueError(f"history={history} is more than the {MAX_FEATURES} potentials "
                             "a model may observe (MAX_FEATURES)")
        if self.grid is not None and frame_size is not None:
            _check_grid(self.grid, *frame_size)
        if int(grid_history) * cells > MAX_FEATURES:
            raise ValueError(f"grid {self.grid[0]}x{self.grid[1]} with grid_history="
                             f"{grid_history} is {int(grid_history) * cells} values, more than "
                             f"the {MAX_FEATURES} a model may observe (MAX_FEATURES)")
        #: Per model, the layer its grid shares out (`lgmd_sim.models.layers`); None
        #: without a grid. A model without layers is refused here, not at its first frame.
        self.layers = {name: None if self.grid is None else needed_layer(
            name, "the grid shares out the activity of", "grid=None observes its "
            "potentials and alarm alone") for name in names}
        self.models = {name: models.make(name, preset=preset, n_streams=int(n_envs), **params)
                       for name in names}
        self.keep_frame = bool(keep_frame)
        n, m = int(n_envs), len(names)
        self._history = np.full((n, m, int(history)), REST, np.float32)
        #: The last step's outputs, per environment and model: (n_envs, n_models).
        self.potential = np.full((n, m), REST)
        self.alarm = np.zeros((n, m), bool)
        self._shares = np.zeros((n, m, int(grid_history), cells), np.float32)
        self.memory = int(memory)
        columns = self.grid[1] if self.memory else 0
        self._memory = np.zeros((n, m, columns), np.float32)
        unit = {"lgmd_potential": m * int(history), "lgmd_alarm": m,
                "lgmd_grid": m * int(grid_history) * cells, "lgmd_memory": m * columns}
        self.spaces = {k: spaces.Box(0.0, 1.0, (size,), np.float32)
                       for k, size in unit.items() if size}

    @property
    def n_envs(self) -> int:
        return len(self._history)

    @property
    def rotation_keys(self) -> list[str]:
        """The ``info`` keys the models need each step (the camera's rotation, for
        ``stabilize="pose"`` or ``"imu"``); empty when the frames are enough."""
        return sorted({m.rotation_key for m in self.models.values()} - {None})

    def observation_space(self, base: gym.Space) -> spaces.Dict:
        """One environment's observation space: `base` (a jitter environment's) with the
        LGMD keys, without the frame unless ``keep_frame``."""
        check_frame_space(base)
        taken = sorted(set(base.spaces) & set(KEYS))
        if taken:
            raise ValueError(f"env: its observation has {', '.join(taken)} already "
                             "(an LGMD wrapper inside another?)")
        kept = {k: s for k, s in base.spaces.items() if self.keep_frame or k != "frame"}
        return spaces.Dict({**kept, **self.spaces})

    def step(self, frames: np.ndarray, new: np.ndarray,
             infos: Sequence[Mapping[str, Any]] | None = None) -> None:
        """Feed one frame per environment, (n_envs, H, W, C) uint8; ``new`` (n_envs,) marks
        the environments whose episode starts with this frame (their streams restart);
        ``infos``, one per environment, give what `rotation_keys` names."""
        new = np.asarray(new, bool)
        if self.rotation_keys and infos is None:
            raise ValueError(f"the models need {', '.join(self.rotation_keys)} from each "
                             "step's info: pass infos")
        potential = np.empty_like(self.potential)
        alarm = np.empty_like(self.alarm)
        shares = np.empty_like(self._shares)
        fade = np.float32(1 / self.memory if self.memory else 0)
        memory = np.where(new[:, None, None], np.float32(0), (self._memory - fade).clip(0))
        for k, (name, model) in enumerate(self.models.items()):
            if new.all():
                model.reset()  # every stream anew: the frame size may change too
            else:
                model.reset(np.flatnonzero(new))
            out = model.step(frames, layers=self.grid is not None,
                             rotation=None if infos is None else model.rotation_from(infos))
            potential[:, k], alarm[:, k] = out.potential, out.alarm
            if self.grid is not None:
                newest = self._cell_shares(out.layers[self.layers[name]])
                # a new stream's older grids are its first: no motion before it
                older = np.where(new[:, None, None], newest[:, None], self._shares[:, k, 1:])
                shares[:, k] = np.concatenate([older, newest[:, None]], axis=1)
                if self.memory:
                    self._remember(memory[:, k], newest, out.potential,
                                   model.params.threshold)
        history = np.where(new[:, None, None], np.float32(REST), self._history)
        self._history = np.concatenate([history[..., 1:], potential[..., None]], axis=-1,
                                       dtype=np.float32)
        self.potential, self.alarm, self._shares = potential, alarm, shares
        self._memory = memory

    def _remember(self, memory: np.ndarray, shares: np.ndarray, potential: np.ndarray,
                  threshold: float) -> None:
        """Raise, in place, each stream's `memory` (n, cols) in the column of its grid's
        largest share to the excitation of its `potential`."""
        column = shares.argmax(axis=1) % self.grid[1]
        excitation = np.clip((np.asarray(potential, np.float64) - REST)
                             / max(float(threshold) - REST, 1e-9), 0.0, 1.0)
        streams = np.arange(len(memory))
        memory[streams, column] = np.maximum(memory[streams, column], excitation)

    def _cell_shares(self, s: np.ndarray) -> np.ndarray:
        """Each grid cell's share of the mean rectified S, (n, H, W) -> (n, rows * cols)."""
        rows, cols = self.grid
        height, width = s.shape[1:]
        _check_grid(self.grid, height, width)  # again: the frame size may change at a reset
        # cell edges: cells differ by at most a pixel in height or width
        r = np.linspace(0, height, rows + 1).astype(int)
        c = np.linspace(0, width, cols + 1).astype(int)
        sums = np.add.reduceat(np.maximum(s, 0.0), r[:-1], axis=1, dtype=np.float64)
        sums = np.add.reduceat(sums, c[:-1], axis=2)
        means = (sums / np.outer(np.diff(r), np.diff(c))).reshape(len(s), -1)
        total = means.sum(axis=1, keepdims=True)
        uniform = np.full_like(means, 1.0 / means.shape[1])
        return np.divide(means, total, out=uniform, where=total > 0)

    def observation(self, base: Mapping[str, np.ndarray], index: int | None = None
                    ) -> dict[str, np.ndarray]:
        """`base` with the LGMD keys (the frame dropped unless ``keep_frame``): `base` is
        environment `index`'s observation, or with index None, all environments' batched."""
        n = self.n_envs
        lgmd = {"lgmd_potential": self._history.reshape(n, -1),
                "lgmd_alarm": self.alarm.astype(np.float32),
                "lgmd_grid": self._shares.reshape(n, -1),
                "lgmd_memory": self._memory.reshape(n, -1)}
        rows = slice(None) if index is None else index
        kept = {k: v for k, v in base.items() if self.keep_frame or k != "frame"}
        return {**kept, **{k: lgmd[k][rows] for k in self.spaces}}

    def info(self, index: int) -> dict[str, dict[str, Any]]:
        """Environment `index`'s model outputs: ``{"lgmd_potential": {name: float},
        "lgmd_alarm": {name: bool}}``."""
        return {"lgmd_potential": {n: float(self.potential[index, k])
                                   for k, n in enumerate(self.models)},
                "lgmd_alarm": {n: bool(self.alarm[index, k]) for k, n in enumerate(self.models)}}

    def vector_info(self, mask: np.ndarray) -> dict[str, Any]:
        """The model outputs of the environments in `mask` as Gymnasium batches per-env
        infos: arrays with zeros elsewhere, each with its ``_key`` mask."""
        out: dict[str, Any] = {}
        for key, values in (("lgmd_potential", self.potential), ("lgmd_alarm", self.alarm)):
            per_model: dict[str, np.ndarray] = {}
            for k, name in enumerate(self.models):
                per_model[name] = np.where(mask, values[:, k], np.zeros((), values.dtype))
                per_model[f"_{name}"] = mask.copy()
            out[key], out[f"_{key}"] = per_model, mask.copy()
        return out

    def ahead(self, frames: np.ndarray, infos: Sequence[Mapping[str, Any]] | None = None
              ) -> LGMDFeatures:
        """A copy that has seen one more frame per environment (and its info), this one
        unchanged: the observation of an episode's last frame once the vector environment
        has reset it (same-step autoreset), every stream's state continued exactly."""
        copied = copy.deepcopy(self)
        copied.step(frames, np.zeros(self.n_envs, bool), infos)
        return copied


class LGMDObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """LGMD models watching the camera: their potentials, alarms and S-layer map observed.

    Adds ``lgmd_potential``, ``lgmd_alarm``, ``lgmd_grid`` and, with a ``memory``,
    ``lgmd_memory`` to the observation and the model outputs to ``info`` (see
    `LGMDFeatures` for the keys, shapes and what the grid and the memory hold). The
    models start new streams at every reset.

    >>> env = LGMDObservation(gym.make("lgmd_sim/RoughTerrainObstacles-v0"), keep_frame=False)
    >>> obs, info = env.reset(seed=0)  # obs["lgmd_potential"]: the last 8 potentials

    Args:
        env: a jitter environment, or any with a Dict observation holding a uint8 "frame".
        model: a name of `lgmd_sim.models.available()` or a plug-in's
            "package.module:Class" spec, or a list of them to compare.
        preset: the models' parameter set (None: each model's default).
        history: number of membrane potentials observed, newest last.
        grid: (rows, cols) of the S-layer summary, at most the frame's (height, width), or
            None for none.
        grid_history: number of grids observed, newest last.
        memory: frames the per-column memory of the excitation lasts (0: none; see
            `LGMDFeatures`).
        keep_frame: keep the camera frame in the observation.
        **params: the models' parameter overrides.

    Raises:
        ValueError: a bad argument, naming it, before anything is allocated (sizes: see
            `LGMDFeatures`).
    """

    def __init__(self, env: gym.Env, model: str | Sequence[str] = "feedback",
                 preset: str | None = None, history: int = 8,
                 grid: tuple[int, int] | None = (1, 3), grid_history: int = 1,
                 memory: int = 0, keep_frame: bool = True, **params: Any) -> None:
        # recorded for env.spec, so that gym.make(env.spec) rebuilds the wrapper
        gym.utils.RecordConstructorArgs.__init__(self, model=model, preset=preset,
                                                 history=history, grid=grid,
                                                 grid_history=grid_history, memory=memory,
                                                 keep_frame=keep_frame, **params)
        gym.Wrapper.__init__(self, env)
        self.features = LGMDFeatures(1, model, preset=preset, history=history, grid=grid,
                                     grid_history=grid_history, memory=memory,
                                     keep_frame=keep_frame,
                                     frame_size=frame_size_of(env.observation_space), **params)
        self.observation_space = self.features.observation_space(env.observation_space)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        return self._observe(obs, info, new=True)

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], Any, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        obs, info = self._observe(obs, info, new=False)
        return obs, reward, terminated, truncated, info

    def _observe(self, obs: dict[str, np.ndarray], info: dict[str, Any], new: bool
                 ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self.features.step(obs["frame"][None], np.array([new]), [info])
        return self.features.observation(obs, 0), {**info, **self.features.info(0)}


class LGMDVectorObservation(VectorWrapper):
    """`LGMDObservation` for a Gymnasium vector environment, with one batched model per
    model name across its environments (``gym.make_vec``, sync or async).

    Observations and infos are those of the vector environment of N separately wrapped
    environments, bit for bit. Autoreset: in next-step mode (Gymnasium's default) the
    streams of the environments that ended restart on the next step, the one returning
    their reset observation; in same-step mode the ended episodes' last observations
    (``info["final_obs"]``, ``info["final_info"]``) come from a copy of the models that
    continues their streams, and the streams restart on the reset observation. Partial
    resets (``reset_mask``, the disabled autoreset mode) are not supported.

    >>> envs = LGMDVectorObservation(gym.make_vec("lgmd_sim/PassBy-v0", 4), keep_frame=False)

    Args:
        env: a vector environment of jitter environments.
        model, preset, history, grid, grid_history, memory, keep_frame, **params: as
            `LGMDObservation`.
    """

    def __init__(self, env: VectorEnv, model: str | Sequence[str] = "feedback",
                 preset: str | None = None, history: int = 8,
                 grid: tuple[int, int] | None = (1, 3), grid_history: int = 1,
                 memory: int = 0, keep_frame: bool = True, **params: Any) -> None:
        super().__init__(env)
        self._mode = AutoresetMode(env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP))
        if self._mode == AutoresetMode.DISABLED:
            raise ValueError("env: autoreset mode 'Disabled' is not supported (it resets "
                             "environments apart); use next-step or same-step autoreset")
        self.features = LGMDFeatures(env.num_envs, model, preset=preset, history=history,
                                     grid=grid, grid_history=grid_history, memory=memory,
                                     keep_frame=keep_frame,
                                     frame_size=frame_size_of(env.single_observation_space),
                                     **params)
        self.single_observation_space = self.features.observation_space(
            env.single_observation_space)
        self.observation_space = batch_space(self.single_observation_space, env.num_envs)
        self._restart = np.zeros(env.num_envs, bool)

    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None) -> tuple[dict[str, np.ndarray], dict]:
        if options and "reset_mask" in options:
            raise ValueError("options: reset_mask (resetting some environments) is not "
                             "supported; reset them all")
        obs, info = self.env.reset(seed=seed, options=options)
        self._restart[:] = False
        return self._observe(obs, info, np.ones(self.num_envs, bool))

    def step(self, actions: Any) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray,
                                          np.ndarray, dict[str, Any]]:
        obs, rewards, terminations, truncations, info = self.env.step(actions)
        done = np.logical_or(terminations, truncations)
        if self._mode == AutoresetMode.NEXT_STEP:
            # this step's observations of last step's ended environments are reset ones
            new, self._restart = self._restart, done
        else:
            new = done
            if done.any():
                info = self._final(info, done, obs["frame"])
        obs, info = self._observe(obs, info, new)
        return obs, rewards, terminations, truncations, info

    def _final(self, info: dict[str, Any], done: np.ndarray, frames: np.ndarray
               ) -> dict[str, Any]:
        """Same-step autoreset: the ended episodes' last observations and infos."""
        final_obs = info["final_obs"].copy()
        last = frames.copy()
        infos = _per_env(info, self.features.rotation_keys, self.num_envs)
        final = _per_env(info["final_info"], self.features.rotation_keys, self.num_envs)
        for i in np.flatnonzero(done):
            last[i] = final_obs[i]["frame"]
            infos[i] = final[i]
        ahead = self.features.ahead(last, infos)
        for i in np.flatnonzero(done):
            final_obs[i] = ahead.observation(final_obs[i], i)
        return {**info, "final_obs": final_obs,
                "final_info": {**info["final_info"], **ahead.vector_info(done)}}

    def _observe(self, obs: dict[str, np.ndarray], info: dict[str, Any], new: np.ndarray
                 ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self.features.step(obs["frame"], new,
                           _per_env(info, self.features.rotation_keys, self.num_envs))
        every = np.ones(self.num_envs, bool)
        return self.features.observation(obs), {**info, **self.features.vector_info(every)}


def _per_env(info: Mapping[str, Any], keys: Sequence[str], n: int) -> list[dict[str, Any]]:
    """A vector environment's batched info as one dict per environment, of `keys` only."""
    return [{k: np.asarray(info[k])[i] for k in keys} for i in range(n)]
