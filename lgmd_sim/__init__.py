"""lgmd-sim: a Gymnasium jitter-robot testbed for bio-inspired (LGMD) collision detection.

Packages, in floors (each imports only from the floors below it; CONTRIBUTING.md draws them):
    core     lgmd_sim.core: params (checked parameters), fileio (atomic outputs), runs (the
             one resumable run folder), parallel (jobs on a pool or on Ray), jobs (a
             job and what it keeps), pool (the worker processes), registry, extras,
             machine, numerics, resources, frames, plots
    signals  lgmd_sim.signals (stimuli, video, noise, metrics), lgmd_sim.models (the LGMD
             family: feedback LGMD, LGMD1, LGMD2, F(ONn), F(OFFp), front ends, presets)
    world    lgmd_sim.world (the MuJoCo jitter world), envs (Gymnasium environments, the
             scenario catalogue, wrappers)
    acting   lgmd_sim.policies (trained policies and what they observe), controllers
             (what drives the carrier; the options every job shares)
    jobs     lgmd_sim.benchmark (episodes, the closed- and open-loop benches, the protocol,
             the leaderboard), detect, data (labelled datasets), calibration, training: each
             job a function taking a typed, frozen configuration (docs/reference/api.md)
    apps     lgmd_sim.apps: demo, record
    command  lgmd_sim.cli (`lgmd-sim`: parses options into a job's configuration)

Importing lgmd_sim registers every scenario of the catalogue as `lgmd_sim/<Name>-v0`.
"""

__version__ = "0.1.0"

# first: the numeric mode is environment variables NumPy and Numba read when imported
from lgmd_sim.core.numerics import pin as _pin

_pin()

from lgmd_sim.envs.catalogue import register_all as _register_all  # noqa: E402

_register_all()  # entry-point strings only: no MuJoCo import until an env is made
