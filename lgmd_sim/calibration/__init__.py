"""Calibration: the same search for every model on recorded clips, judged by a declared
objective on clips it never saw (`lgmd-sim calibrate`: `CalibrateConfig` -> `calibrate`,
in `lgmd_sim.calibration.run`).

- `lgmd_sim.calibration.objective`: every clip a hit or a miss (the walker's clips);
- `lgmd_sim.calibration.robot`: the robot task's objective: an alarm in the manoeuvre's
  window, silence beyond the horizon;
- `lgmd_sim.calibration.clips`: the clips, recorded once;
- `lgmd_sim.calibration.search`: each model's free parameters and one candidate's score;
- `lgmd_sim.calibration.tasks`: the tasks (clips and objective) and their presets' names;
- `lgmd_sim.calibration.report`: the summary table and figure of the chosen candidates;
- `lgmd_sim.calibration.redraw`: that figure drawn again from a run or a presets file.
"""
