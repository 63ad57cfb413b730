"""What a benchmark row runs (an `Entry`), from what a user types: a detector (a model
spec with its preset and front ends) driving the reference controller ("@eyes": with two
LGMDs) or another controller driven by a detector ("@loom-steer"), a controller of its
own, or a policy folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lgmd_sim.benchmark.episode import Cell

__all__ = ["REFERENCE", "SIDES", "Entry", "driver", "parse"]

#: The longest entry taken (a path of 4,096 characters is Linux's longest).
MAX_SPEC = 4096
#: The reference controller a detector drives (`lgmd_sim.controllers.avoid.ReactiveAvoid`
#: with its constants as they ship), and the ways it reads a side from the detector.
REFERENCE = "reactive"
SIDES = ("halves", "eyes")


@dataclass(frozen=True)
class Entry:
    """One row of the leaderboard.

    Attributes:
        spec: as the user gave it ("lgmd1/robot-image@eyes", "oracle", "runs/ppo").
        kind: "detector" (a model driving `REFERENCE` or another controller that takes
            one), "controller" or "policy".
        controller: the controller of its cells.
        model, preset: the detector (a detector entry).
        side: how the reference controller reads the side ("halves" or "eyes").
        policy: the policy folder (a policy entry).
    """

    spec: str
    kind: str
    controller: str
    model: str | None = None
    preset: str | None = None
    side: str = "halves"
    policy: Path | None = None

    @property
    def label(self) -> str:
        """The row's name."""
        if self.kind == "detector":
            return (f"{self.model}/{self.preset}" + ("" if self.side == "halves" else "@eyes")
                    + ("" if self.controller == REFERENCE else f"@{self.controller}"))
        if self.kind == "policy":
            from lgmd_sim.policies import name_of

            return f"policy:{name_of(self.policy)}"
        return self.controller

    @property
    def key(self) -> str:
        """The entry's folder name: its label, with "-" for the preset's "/" and "@"."""
        from lgmd_sim.controllers.options import file_key

        return file_key(self.label).replace("/", "-").replace("@", "-")

    def bench_options(self, scenario: str, jitter: tuple[float, ...]) -> dict[str, Any]:
        """The closed-loop bench's options (`lgmd_sim.benchmark.closed_loop.ClosedLoopConfig`)
        that run the entry's cells alone in `scenario` at each level of `jitter`."""
        if self.kind == "detector":
            return {"controllers": (self.controller,), "detectors": ((self.model, self.preset),),
                    "sides": (self.side,)}
        if self.kind == "policy":
            from lgmd_sim.policies import name_of

            return {"controllers": (), "extra": tuple(
                Cell(scenario, j, "policy", params=(("path", str(self.policy)),),
                     tag=name_of(self.policy)) for j in jitter)}
        return {"controllers": (self.controller,)}

    def to_json(self) -> dict[str, Any]:
        """What a result records of the entry, its detector's parameters resolved."""
        out: dict[str, Any] = {"spec": self.spec, "kind": self.kind, "label": self.label,
                               "controller": self.controller}
        if self.kind == "detector":
            import dataclasses

            from lgmd_sim import models

            out.update(model=self.model, preset=self.preset, side=self.side,
                       params=dataclasses.asdict(models.make(self.model,
                                                             preset=self.preset).params))
            if self.controller != REFERENCE:  # its constants, as it resolves them
                from lgmd_sim import controllers

                resolved = controllers.controller_class(self.controller).resolve(
                    model=self.model, preset=self.preset)
                out["controller_params"] = {
                    k: v for k, v in dataclasses.asdict(resolved).items()
                    if k not in ("model", "preset", "model_params")}
        if self.kind == "policy":
            out["policy"] = str(self.policy)
        return out


def driver(how: str) -> tuple[str, str]:
    """The controller a detector drives and the reference controller's side, from what
    follows the detector (after "@" in an entry, after "," in the demo's ``--avoider``): a
    side of `SIDES` (the reference controller), or a controller that a detector drives
    (at the default side).

    Raises:
        ValueError: neither, in words that follow "after '@' comes".
    """
    from lgmd_sim import controllers

    if how in SIDES:
        return REFERENCE, how
    try:
        if controllers.controller_class(how).uses_model:
            return how, SIDES[0]
        why = ""
    except ValueError as exc:
        why = f" ({exc})"
    raise ValueError(f"a side ({', '.join(SIDES)}) or a controller that a detector drives "
                     f"(e.g. loom-steer), not {how!r}{why}")


def parse(spec: str) -> Entry:
    """The entry `spec` names: a controller's name or spec ("oracle", "straight",
    "mypkg.drive:Mine"), a policy (a folder holding policy.json, or a shipped policy's
    name), or else a detector ("model", "model/preset+front", a "package.module:Class"
    spec; "@eyes" after it for two LGMDs over the left and right of the view).

    Raises:
        ValueError: none of those, or a detector without layers at the reference
            controller's default side (the halves of a layer; "@eyes" needs none), in one
            line naming `spec`.
    """
    from lgmd_sim import controllers, models, policies

    text = spec.strip()
    if not text:
        raise ValueError("an entry is a detector, a controller or a policy folder, got ''")
    if len(text) > MAX_SPEC:
        raise ValueError(f"entry {text[:40]!r}... is {len(text):,} characters: an entry is a "
                         "detector, a controller or a policy folder")
    if text in ("shipped", *policies.available()) or (Path(text) / "policy.json").is_file():
        return Entry(spec, "policy", "policy", policy=policies.resolve(text).resolve())
    if text.startswith((".", "/", "~")) or text.endswith("/"):  # a path, not a name
        raise ValueError(f"entry {spec!r}: no policy folder there (no "
                         f"{Path(text) / 'policy.json'})")
    if text == "policy":
        raise ValueError("entry 'policy': name the policy's folder (or 'shipped')")
    if text in controllers.available() and controllers.controller_class(text).uses_model:
        raise ValueError(f"entry {text!r}: name the detector it drives (e.g. " + (
            "lgmd1)" if text == REFERENCE else f"lgmd1@{text})"))
    if text in controllers.available():
        return Entry(spec, "controller", text)
    head, at, how = text.partition("@")
    try:
        controller, side = driver(how) if at else (REFERENCE, SIDES[0])
    except ValueError as exc:
        raise ValueError(f"entry {spec!r}: after '@' comes {exc}") from None
    try:
        name, preset = models.parse_spec(head)
    except ValueError as exc:
        try:  # a plug-in controller by its spec
            controllers.controller_class(text)
        except ValueError:
            raise ValueError(f"entry {spec!r}: not a controller, a policy folder or a "
                             f"detector ({exc})") from None
        return Entry(spec, "controller", text)
    if controller == REFERENCE and side == "halves":
        # refused with the other entries, before any runs, not in its first episode
        from lgmd_sim.models.layers import needed_layer

        needed_layer(name, f"entry {spec!r}: the reference controller tells the threat's "
                     "side by the left and right halves of", f"give it two LGMDs, {head}@eyes")
    return Entry(spec, "detector", controller, name, preset, side)
