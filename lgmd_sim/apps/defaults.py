"""The demo's defaults: what `lgmd-sim demo` shows when given no option. A module of its own
and without imports, so that the command's --help reads them without loading the demo."""

#: The feedback LGMD at its robot calibration, the rotation fitted from the frames: the
#: preset made for this camera (docs/concepts.md, "Presets").
BEST = "feedback/robot-image"
#: An episode in which it alarms 0.8 s before the collision and the paper's model in the
#: first frames, from the shake; not every episode goes so (at seed 0 it stays silent):
#: the leaderboard gives the rates.
SEED = 2
#: What the demo shows by default: the best detector, then the paper's model.
DETECTORS = (BEST, "feedback/paper")
#: The detector that drives ReactiveAvoid in the closed-loop episode, and how it tells the
#: threat's side ("DETECTOR[,SIDE]"): the one that reached the goal most often on the
#: robot benchmark's search seeds at jitter 1 (LGMD2 with the IMU's rotation removed, its
#: robot calibration, two eyes); its held-out rates are in docs/experiments/results-log.md.
AVOIDER = "lgmd2/robot-imu,eyes"
#: An episode (a search seed of that benchmark) in which it avoids the obstacles in the
#: way and reaches the goal, with four alarms and none false. Not every episode goes so:
#: docs/experiments/results-log.md gives the rates.
AVOID_SEED = 309
