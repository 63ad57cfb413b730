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
#: The detector that drives the robot in the closed-loop episode, and how
#: ("DETECTOR[,HOW]"): the best hand-made LGMD controller of the leaderboard, LoomSteer
#: steered by LGMD1 at its robot preset with the rotation fitted from the frames.
AVOIDER = "lgmd1/robot-image,loom-steer"
#: An episode (a search seed of LoomSteer's, docs/experiments/loom-steer.md) in which it
#: reaches the goal at frame 609 with five alarms, in the replay mode on any x86-64
#: processor with AVX2 (`lgmd_sim.core.numerics`; recorded on an AMD EPYC, and checked,
#: potentials to the bit, by tests/benchmark/test_replay.py on whichever processor runs the suite).
#: Not every episode goes so: the leaderboard gives the rates.
AVOID_SEED = 2002
