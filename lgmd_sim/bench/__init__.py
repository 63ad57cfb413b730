"""The model benchmark: `lgmd-sim bench closed-loop` (controllers driving with each
detector: `closed_loop`, `ClosedLoopConfig` -> `closed_loop.run`; one episode and its
record: `episode`; the per-cell summary and tables: `summary`) and `lgmd-sim bench
open-loop` (every model on the same clips: `open_loop`, `OpenLoopConfig` ->
`open_loop.run`), and their figures (`figures`). Each run keeps its results in an
`lgmd_sim.core.runs.RunFolder`."""
