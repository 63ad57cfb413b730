"""The benchmark: one protocol, one command, one leaderboard.

- `lgmd_sim.benchmark.protocol`: the protocol as data (``v1.toml``): tracks, scenarios,
  jitter levels, seeds, frame size, calibration rule;
- `lgmd_sim.benchmark.scores`: the headline score of each track and the overall one, from
  the episodes' records, with bootstrap intervals and paired comparisons.
"""
