"""The benchmark's protocol as data: its tracks, their scenarios, jitter levels and seeds,
the frame size, the reference controller's cruise, the calibration rule and the bootstrap,
read from a versioned TOML file (`PROTOCOLS`: ``v1.toml``, ``v2.toml`` beside this module)
and checked key by key, so that a bad file is one line naming it and the key.

Version 1 scores detection on synthetic clips (`DetectionTrack`); version 2 on the robot's
own camera (`CameraTrack`), keeps the synthetic clips as the "stimuli" track, and runs the
closed-loop tracks at more jitter levels. A file's ``version`` key says which it is.
"""

from __future__ import annotations

import dataclasses
import hashlib
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lgmd_sim.core.fileio import read_text
from lgmd_sim.core.params import checked, count, finite, in_range, positive, seed

__all__ = ["CURRENT", "PROTOCOLS", "SMOKE_SEEDS", "ArenaTrack", "Calibration", "CameraTrack",
           "ClosedLoopTrack", "DetectionTrack", "Protocol", "load"]

_HERE = Path(__file__).resolve().parent
#: The shipped protocols, by name.
PROTOCOLS = {p.stem: p for p in sorted(_HERE.glob("v*.toml"))}
#: The protocol `lgmd-sim benchmark` runs by default.
CURRENT = "v2"
#: Seeds a track of a smoke run (`Protocol.smoke`).
SMOKE_SEEDS = 2
#: The most bootstrap resamples a protocol may ask: its draws are resamples x seeds
#: integers per track (100,000 x 40 seeds: 32 MB), computed again for every comparison.
MAX_BOOTSTRAP = 100_000


@dataclass(frozen=True)
class ClosedLoopTrack:
    """A closed-loop track: `episodes` episodes (seeds `first_seed` on) of `scenario` at
    each jitter level, the same seeds for every entry."""

    scenario: str
    jitter: tuple[float, ...]
    first_seed: int
    episodes: int

    @property
    def seeds(self) -> list[int]:
        return list(range(self.first_seed, self.first_seed + self.episodes))


@dataclass(frozen=True)
class ArenaTrack(ClosedLoopTrack):
    """The arena track: a closed-loop track whose score weighs the distance travelled by
    `reference_distance_m`, the Oracle's mean distance at each jitter level."""

    reference_distance_m: tuple[float, ...] = ()


@dataclass(frozen=True)
class DetectionTrack:
    """The open-loop track: `clips` clips (seeds `first_seed` on) of every stimulus, at each
    jitter level; a hit is the first alarm within `window_s` before the collision."""

    approaching: tuple[str, ...]
    non_approach: tuple[str, ...]
    jitter: tuple[float, ...]
    first_seed: int
    clips: int
    window_s: float

    @property
    def seeds(self) -> list[int]:
        return list(range(self.first_seed, self.first_seed + self.clips))


@dataclass(frozen=True)
class CameraTrack:
    """The detection track of version 2 (`lgmd_sim.benchmark.camera`): `clips` clips
    (seeds `first_seed` on) of every robot scenario, `approaching` (driving at an obstacle)
    and `clear`, at each jitter level; clip i drives at forward action ``cruise[i %
    len(cruise)]``. An alarm must come while the threat's time to collision is within
    `window_s` (low, high); none while no threat is within the protocol's horizon."""

    approaching: tuple[str, ...]
    clear: tuple[str, ...]
    jitter: tuple[float, ...]
    cruise: tuple[float, ...]
    first_seed: int
    clips: int
    window_s: tuple[float, ...]

    @property
    def seeds(self) -> list[int]:
        return list(range(self.first_seed, self.first_seed + self.clips))

    def cruise_of(self, seed: int) -> float:
        """The forward action of the clips of `seed`."""
        return self.cruise[(seed - self.first_seed) % len(self.cruise)]


@dataclass(frozen=True)
class Calibration:
    """The calibration `lgmd-sim benchmark --calibrate` runs (`lgmd-sim calibrate`'s
    options of those names)."""

    task: str
    budget: int
    seeds: int
    first_seed: int
    heldout_seed: int


@dataclass(frozen=True)
class Protocol:
    """A version of the benchmark (see the TOML file's comments for each key)."""

    version: int
    resolution: str
    cruise: float
    horizon: float
    bootstrap: int
    bootstrap_seed: int
    goal: ClosedLoopTrack
    arena: ArenaTrack
    #: Version 1: synthetic clips; version 2: the robot's camera.
    detection: DetectionTrack | CameraTrack
    calibration: Calibration
    #: The file it was read from, and the SHA-256 of its bytes (what a result records).
    path: Path
    digest: str
    #: Version 2: the synthetic clips, a table of their own outside the overall score.
    stimuli: DetectionTrack | None = None
    #: A smoke run's protocol (`smoke`): a handful of seeds, never ranked.
    smoke_run: bool = False

    @property
    def name(self) -> str:
        """A shipped protocol's name ("v1") where the file is that one to the byte, else
        the file's own, saying so: a protocol of one's own is never taken for a shipped
        version, whatever its `version` key says."""
        shipped = next((name for name, path in PROTOCOLS.items()
                        if hashlib.sha256(path.read_bytes()).hexdigest() == self.digest), None)
        own = shipped or f"{self.path.name} (a protocol of one's own, version {self.version})"
        return f"{own}, smoke run" if self.smoke_run else own

    def identity(self) -> dict[str, Any]:
        """What a result records of the protocol it ran."""
        return {"version": self.version, "sha256": self.digest,
                **({"smoke": True} if self.smoke_run else {})}

    def smoke(self) -> Protocol:
        """This protocol on `SMOKE_SEEDS` seeds a track (one clip a stimulus and level) and
        a calibration of `SMOKE_SEEDS` settings on one seed: every track and every part of
        an entry run, to see its errors and its output in a few minutes. Its results are
        marked, and no leaderboard ranks them."""
        few = dataclasses.replace
        return few(self, goal=few(self.goal, episodes=min(SMOKE_SEEDS, self.goal.episodes)),
                   arena=few(self.arena, episodes=min(SMOKE_SEEDS, self.arena.episodes)),
                   detection=few(self.detection, clips=1),
                   stimuli=None if self.stimuli is None else few(self.stimuli, clips=1),
                   calibration=few(self.calibration, seeds=1,
                                   budget=min(SMOKE_SEEDS, self.calibration.budget)),
                   smoke_run=True)


def _is(value: Any, kind: type) -> bool:
    if kind is float:  # the parameters' check: an integer is a float here, true is none
        return finite(value) is None
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, kind)


#: Each table's keys and their types: tuple[...] is a non-empty array of them.
_SHAPES: dict[type, dict[str, Any]] = {
    ClosedLoopTrack: {"scenario": str, "jitter": (float,), "first_seed": int, "episodes": int},
    ArenaTrack: {"scenario": str, "jitter": (float,), "first_seed": int, "episodes": int,
                 "reference_distance_m": (float,)},
    DetectionTrack: {"approaching": (str,), "non_approach": (str,), "jitter": (float,),
                     "first_seed": int, "clips": int, "window_s": float},
    CameraTrack: {"approaching": (str,), "clear": (str,), "jitter": (float,),
                  "cruise": (float,), "first_seed": int, "clips": int, "window_s": (float,)},
    Calibration: {"task": str, "budget": int, "seeds": int, "first_seed": int,
                  "heldout_seed": int},
}
_V1 = {"version": int, "resolution": str, "cruise": float, "horizon": float,
       "bootstrap": int, "bootstrap_seed": int, "goal": ClosedLoopTrack,
       "arena": ArenaTrack, "detection": DetectionTrack, "calibration": Calibration}
#: Each version's keys.
_TOP = {1: _V1, 2: {**_V1, "detection": CameraTrack, "stimuli": DetectionTrack}}


def _table(data: Any, shape: Mapping[str, Any], where: str) -> dict[str, Any]:
    """`data` checked against `shape` (key -> type, (type,) for an array, or a table's
    dataclass), its arrays as tuples and tables as dataclasses."""
    if not isinstance(data, dict):
        raise ValueError(f"{where or 'the file'} is not a table")
    unknown = sorted(set(data) - set(shape))
    missing = [k for k in shape if k not in data]
    if unknown or missing:
        what = (f"unknown key {where}{unknown[0]} (a protocol has {', '.join(shape)})"
                if unknown else f"no key {where}{missing[0]}")
        raise ValueError(what)
    out = {}
    for key, kind in shape.items():
        value, at = data[key], f"{where}{key}"
        if kind in _SHAPES:
            out[key] = kind(**_table(value, _SHAPES[kind], f"{at}."))
        elif isinstance(kind, tuple):
            if not (isinstance(value, list) and value and all(_is(v, kind[0]) for v in value)):
                raise ValueError(f"{at} must be a non-empty array of {kind[0].__name__}s, got "
                                 f"{value!r}")
            out[key] = tuple(float(v) if kind[0] is float else v for v in value)
        elif not _is(value, kind):
            raise ValueError(f"{at} must be {'a' if kind is not int else 'an'} "
                             f"{kind.__name__}, got {value!r}")
        else:
            out[key] = float(value) if kind is float else value
    return out


def _check(p: Protocol) -> None:
    """The values a well-formed protocol may not hold: one line naming the key."""
    from lgmd_sim.calibration.tasks import TASKS
    from lgmd_sim.controllers import options
    from lgmd_sim.envs.catalogue import scenarios

    options.resolution(p.resolution, "resolution")
    checked("cruise", p.cruise, in_range(-1.0, 1.0))
    checked("version", p.version, count)
    checked("bootstrap", p.bootstrap, count)
    if p.bootstrap > MAX_BOOTSTRAP:
        raise ValueError(f"bootstrap must be at most {MAX_BOOTSTRAP:,} resamples, got "
                         f"{p.bootstrap:,}")
    checked("bootstrap_seed", p.bootstrap_seed, seed)
    known = scenarios()
    for name in ("goal", "arena"):
        track: ClosedLoopTrack = getattr(p, name)
        if track.scenario not in known:
            raise ValueError(f"{name}.scenario {track.scenario!r} is not a scenario "
                             "(lgmd-sim envs lists them)")
        checked(f"{name}.jitter", track.jitter, options.jitter_list)
        checked(f"{name}.episodes", track.episodes, count)
        checked(f"{name}.first_seed", track.first_seed, seed)
    if p.version >= 2:  # each track's dose-response: J50 reads a jitter-0 score, then more
        for name in ("goal", "detection"):
            levels = getattr(p, name).jitter
            if levels[0] != 0 or list(levels) != sorted(levels):
                raise ValueError(f"{name}.jitter must rise from 0 (J50 halves the jitter-0 "
                                 f"score), got {list(levels)}")
        if p.arena.jitter != p.goal.jitter:
            raise ValueError("arena.jitter must be goal.jitter: the overall score at a level "
                             "is the mean of the two tracks' there")
    reference = p.arena.reference_distance_m
    if len(reference) != len(p.arena.jitter) or min(reference) <= 0:
        raise ValueError("arena.reference_distance_m must hold a distance > 0 per jitter level")
    if isinstance(p.detection, CameraTrack):
        _check_camera(p.detection, known)
    for key, track in (("detection", p.detection), ("stimuli", p.stimuli)):
        if isinstance(track, DetectionTrack):
            _check_stimuli(track, key)
    checked("horizon", p.horizon, positive)
    c = p.calibration
    if c.task not in TASKS:
        raise ValueError(f"calibration.task {c.task!r} is none of {', '.join(TASKS)}")
    checked("calibration.budget", c.budget, count)
    checked("calibration.seeds", c.seeds, count)
    checked("calibration.first_seed", c.first_seed, seed)
    checked("calibration.heldout_seed", c.heldout_seed, seed)
    if abs(c.first_seed - c.heldout_seed) < c.seeds:
        raise ValueError("calibration: the search seeds (first_seed on) and the held-out ones "
                         f"(heldout_seed on) overlap, {c.seeds} of each")


def _each_once(track: Any, name: str, keys: tuple[str, str], what: str,
               problem: Callable[[str], str | None]) -> None:
    """Every item of the track's two lists `keys` checked (`problem`: what is wrong with
    it, or None) and given once in all, or a one-line ValueError naming the key."""
    seen: dict[str, str] = {}
    for key in keys:
        for item in getattr(track, key):
            wrong = problem(item)
            if wrong:
                raise ValueError(f"{name}.{key}: {what} {item!r} {wrong}")
            if item in seen:
                raise ValueError(f"{name}.{key}: {what} {item!r} is in {name}.{seen[item]} "
                                 f"already: give each {what} once")
            seen[item] = key


def _check_stimuli(d: DetectionTrack, name: str) -> None:
    from lgmd_sim.calibration.clips import STIMULI
    from lgmd_sim.controllers import options

    _each_once(d, name, ("approaching", "non_approach"), "stimulus",
               lambda s: None if s in STIMULI else f"is none of {', '.join(STIMULI)}")
    checked(f"{name}.jitter", d.jitter, options.jitter_list)
    checked(f"{name}.clips", d.clips, count)
    checked(f"{name}.first_seed", d.first_seed, seed)
    checked(f"{name}.window_s", d.window_s, positive)


def _check_camera(d: CameraTrack, known: Any) -> None:
    from lgmd_sim.controllers import options
    from lgmd_sim.envs.catalogue import params_for

    def problem(scenario: str) -> str | None:
        if scenario not in known:
            return "is not a scenario (lgmd-sim envs lists them)"
        if params_for(scenario, {}).carrier != "robot":
            return "does not carry the camera on the robot"
        return None

    _each_once(d, "detection", ("approaching", "clear"), "scenario", problem)
    checked("detection.jitter", d.jitter, options.jitter_list)
    for speed in d.cruise:
        if not 0 < speed <= 1:
            raise ValueError(f"detection.cruise: {speed:g} is not a forward action in (0, 1]")
    checked("detection.clips", d.clips, count)
    checked("detection.first_seed", d.first_seed, seed)
    if len(d.window_s) != 2 or not 0 <= d.window_s[0] < d.window_s[1]:
        raise ValueError("detection.window_s must be [low, high], 0 <= low < high (s to "
                         f"collision), got {list(d.window_s)}")


def load(spec: str | Path = CURRENT) -> Protocol:
    """The protocol `spec` names: a shipped one (`PROTOCOLS`: "v1") or a TOML file.

    Raises:
        ValueError: an unknown name; a file that cannot be read, is not TOML, lacks a key,
            has one it does not know or a value of the wrong kind (one line naming the file
            and the key).
    """
    path = PROTOCOLS.get(str(spec), Path(spec))
    if str(spec) not in PROTOCOLS and path.suffix != ".toml":
        raise ValueError(f"unknown protocol {str(spec)!r}: a shipped one "
                         f"({', '.join(PROTOCOLS)}) or a .toml file")
    text = read_text(path)
    try:
        data = tomllib.loads(text)
        version = data.get("version")
        if version not in _TOP:
            raise ValueError(f"version is {version!r}: a protocol is of version "
                             f"{' or '.join(map(str, _TOP))} (its keys differ)")
        values = _table(data, _TOP[version], "")
        protocol = Protocol(**values, path=path,
                            digest=hashlib.sha256(text.encode()).hexdigest())
        _check(protocol)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"protocol {path}: not TOML ({exc})") from None
    except ValueError as exc:
        raise ValueError(f"protocol {path}: {exc}") from None
    return protocol

