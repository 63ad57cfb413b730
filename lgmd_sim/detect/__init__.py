"""`lgmd-sim detect`: run LGMD models over videos; write a CSV, a JSON summary and a figure.

- `lgmd_sim.detect.results`: what a detection gives back (`Detection`, `ModelTrace`);
- `lgmd_sim.detect.clip`: the detection loop (`detect` on any frames, `detect_video` on a
  file or image folder);
- `lgmd_sim.detect.specs`: the models to run, from a preset and the video front ends;
- `lgmd_sim.detect.outputs` and `lgmd_sim.detect.figure`: the files and the figure;
- `lgmd_sim.detect.job`: the command as a job (`DetectConfig` -> `run`).

>>> from lgmd_sim.detect import detect_video
>>> d = detect_video("run.mp4", ["feedback", "lgmd2"], collision_frame=120)
>>> d.isi, d.models["feedback"].first_alarm, d.models["feedback"].event.outcome
"""

from lgmd_sim.detect.clip import check_collision_frame, detect, detect_video
from lgmd_sim.detect.job import DetectConfig, Video, run
from lgmd_sim.detect.outputs import output_names, write_outputs
from lgmd_sim.detect.results import Detection, ModelTrace
from lgmd_sim.detect.specs import front_end_params, with_preset

__all__ = ["DetectConfig", "Detection", "ModelTrace", "Video", "check_collision_frame",
           "detect", "detect_video", "front_end_params", "output_names", "run",
           "with_preset", "write_outputs"]
