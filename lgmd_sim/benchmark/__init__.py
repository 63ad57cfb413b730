"""Evaluation: episodes, the closed- and open-loop benches, the benchmark and its leaderboard.

- `episode`: one closed-loop episode and its record (`Cell` -> `episode`); `encounters`,
  `fingerprint`: what a record holds of obstacles met and of the trajectory's bits;
- `closed_loop`, `open_loop`: `lgmd-sim bench` (`ClosedLoopConfig` / `OpenLoopConfig` ->
  `run`), each run kept in an `lgmd_sim.core.runs.RunFolder`; `summary`, `figures`: their
  per-cell tables and figures;
- `protocol`: the benchmark's protocol as data (``v1.toml``, ``v2.toml``): tracks,
  scenarios, jitter levels, seeds, frame size, calibration rule; `entries`, `baselines`:
  what can be benchmarked;
- `run`, `detection`, `camera`: `lgmd-sim benchmark`, one row; `scores`: each track's
  headline score and the overall one, with bootstrap intervals and paired comparisons;
- `leaderboard`, `audit`, `verify`: the table of rows, the checks a result file must pass,
  and the replay of a row's episodes.
"""
