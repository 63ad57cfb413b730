"""The calibration tasks (`TASKS`) and the preset names each gives its detectors.

A task is the clips and the objective they are judged by: "walker" (a hand-held, mutual or
steady camera; `lgmd_sim.calibration.objective`), "robot" (the robot driving at obstacles
and past them; `lgmd_sim.calibration.robot`) or "video" (footage from a camera nobody
calibrated: the walker's clips and synthetic stimuli that do not loom, with a real
camera's noise, every detector with the front end a video allows, `VIDEO`).

Apart from the job (`lgmd_sim.calibration.run`) because the benchmark's protocol checks
its calibration's task against them, and the pages and the redrawn figures name their
presets, without running a calibration.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from lgmd_sim.calibration import clips as clip_mod
from lgmd_sim.calibration.objective import VIDEO, WALKER, Objective
from lgmd_sim.calibration.robot import ROBOT, ROBOT_FRAMES
from lgmd_sim.calibration.search import CONTROLS, space
from lgmd_sim.envs.zone import CRUISE
from lgmd_sim.signals.metrics import PAPER_ALARM
from lgmd_sim.world.params import frame_size

__all__ = ["TASKS", "Task", "preset_name"]


@dataclass(frozen=True)
class Task:
    """What a calibration is about: its clips, the objective that judges them, and the
    name its presets start with.

    Attributes:
        objective, groups (as `lgmd_sim.calibration.clips.DEFAULT_GROUPS`), prefix.
        cruise: the forward action the clips are driven at (None: Straight's).
        fronts: the front ends its clips keep the motions of, which its detectors may have.
        front: None, or the front end every detector has (given or not), which its presets'
            names leave out: the presets are the front end and the model together.
        looks: the families of looks its clips are recorded in
            (`lgmd_sim.calibration.clips.Looks`): "" the search and held-out sets', and
            each other a set of its own, of the held-out seeds (a transfer check).
        fovy: None, or the vertical field of view (degrees) the front end assumes, with the
            scenes' cameras drawn around it (`lgmd_sim.calibration.clips.record_clip`).
        at_clip_size: the presets shrink every frame to the clips' height
            (``working_height``), so that they see a video of any size as they saw the
            clips: a model's kernels and thresholds are in pixels.
    """

    objective: Objective
    groups: Mapping[str, list[tuple[str, tuple[float, ...]]]]
    prefix: str
    cruise: float | None = None
    fronts: tuple[str, ...] = ("image", "imu")
    front: str | None = None
    looks: Mapping[str, clip_mod.Looks] = field(
        default_factory=lambda: {"": clip_mod.Looks()})
    fovy: float | None = None
    at_clip_size: bool = False

    def identity(self) -> dict[str, Any]:
        """What a run folder records of the task beyond its groups and objective."""
        return {"looks": {name: dataclasses.asdict(v) for name, v in self.looks.items()},
                "fovy": self.fovy}

    def preset_params(self, front: str | None, resolution: str | Sequence[int]
                      ) -> dict[str, Any]:
        """The model parameters this task fixes in its presets, beside the searched ones
        and the threshold: front end `front`'s, the clips' height (`at_clip_size`, clips
        of `resolution`) and the objective's alarm rule where it is not the paper's."""
        out: dict[str, Any] = {}
        if front is not None:
            stabilize, _, gain = front.partition("+")
            out.update(stabilize=stabilize, **({"gain": True} if gain else {}),
                       **({"fovy": self.fovy} if self.fovy else {}))
        if self.at_clip_size:
            out["working_height"] = frame_size(resolution)[0]
        if self.objective.alarm != PAPER_ALARM:
            out.update(alarm_frames=self.objective.alarm.frames,
                       alarm_rising=self.objective.alarm.rising)
        return out


#: The calibration tasks: the walker's clips (today's calibrated presets), the robot's,
#: driven at the closed-loop benchmark's cruise, and the video task's.
TASKS: dict[str, Task] = {
    "walker": Task(WALKER, clip_mod.DEFAULT_GROUPS, "calibrated"),
    "robot": Task(ROBOT, clip_mod.ROBOT_GROUPS, "robot", CRUISE),
    "robot-frames": Task(ROBOT_FRAMES, clip_mod.ROBOT_GROUPS, "robot-frames",
                         CRUISE),
    "video": Task(VIDEO, clip_mod.VIDEO_GROUPS, "video", fronts=("image+gain",),
                  front="image+gain", looks=clip_mod.VIDEO_LOOKS, fovy=clip_mod.VIDEO_FOVY,
                  at_clip_size=True),
}


def preset_name(detector: str, task: str = "walker") -> tuple[str, str]:
    """The (model, preset) a calibrated detector becomes: the task's prefix ("calibrated",
    "robot", "video"), for the feedback LGMD's control "calibrated-open-loop", with a
    front end "calibrated-image", "robot-open-loop-imu" ... (not the task's own front end:
    "video")."""
    sp = space(detector)
    name = TASKS[task].prefix + ("-open-loop" if detector.partition("+")[0] in CONTROLS
                                 else "")
    return sp.model, name + (f"-{sp.front}" if sp.front and sp.front != TASKS[task].front
                             else "")
