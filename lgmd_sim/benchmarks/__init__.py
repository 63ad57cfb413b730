"""Speed benchmarks behind ``lgmd-sim bench``: each prints figures measured in one run.

- `lgmd_sim.benchmarks.models`: frames/s of every LGMD model on one core, streaming and
  batched, against its per-equation reference implementation.
"""
