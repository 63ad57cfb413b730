"""What an LGMD-driven controller is given: a detector (a model, its preset and parameter
overrides), and the two eyes it may watch through (`lgmd_sim.models.sectors.Sectors`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from lgmd_sim import models
from lgmd_sim.controllers.straight import DESIGN
from lgmd_sim.core.params import CheckedParams, param
from lgmd_sim.models.sectors import Sectors, below_one

__all__ = ["DetectorParams", "eye_overlap", "eyes"]


def eye_overlap(doc: str = "the share of the view's width both eyes see") -> Any:
    """The parameter of how much of the view two eyes share (Gary2017's two LGMDs)."""
    return param(0.2, "Gary2017: the eyes see 0-60% and 40-100% of the width",
                 check=below_one, doc=doc)


def _model_check(v: Any) -> str | None:
    """A model name or a plug-in's "package.module:Class" spec (`lgmd_sim.models`)."""
    if not isinstance(v, str):
        return "must be a model name or a 'package.module:Class' spec"
    try:
        models.model_class(v)
    except ValueError as exc:
        return str(exc)
    return None


@dataclass(frozen=True)
class DetectorParams(CheckedParams):
    """The LGMD model a controller is driven by."""

    model: str = param("feedback", DESIGN, check=_model_check,
                       doc="the LGMD model: a name of lgmd_sim.models.available() or a "
                           "'package.module:Class' spec")
    preset: str | None = param(None, "the model's default preset",
                               doc="its preset, with front ends (e.g. 'calibrated+image')")
    model_params: Mapping[str, Any] = field(
        default_factory=dict, metadata={"source": DESIGN, "check": None,
                                        "doc": "parameter overrides of the model"})


def eyes(p: DetectorParams, overlap: float) -> Sectors:
    """Two LGMDs of the detector over the left and right of the view, sharing `overlap`
    of its width; ``step(frame).potential`` is (left, right)."""
    return Sectors(p.model, preset=p.preset, columns=2, rows=1, overlap=overlap,
                   **dict(p.model_params))
