"""lgmd-sim: a Gymnasium jitter-robot testbed for bio-inspired (LGMD) collision detection.

Packages:
    lgmd_sim.models      the LGMD model family (feedback LGMD, LGMD1, LGMD2, F(ONn), F(OFFp))
    lgmd_sim.metrics     ISI, MpSI, SI and event metrics (hits, false alarms, lead time)
    lgmd_sim.stimuli     seeded synthetic stimuli (looming, receding, translating, jitter)
    lgmd_sim.world       the MuJoCo jitter world: terrain, robot, camera carriers, obstacles
    lgmd_sim.envs        Gymnasium environments, the scenario catalogue and wrappers
    lgmd_sim.controllers what drives the camera's carrier; the episode loop
    lgmd_sim.bench       the model benchmark (`lgmd-sim bench closed-loop|open-loop`)
    lgmd_sim.calibration `lgmd-sim calibrate`: the same search for every model
    lgmd_sim.data        labelled datasets: generate, verify, load
    lgmd_sim.noise       the paper's Gaussian and salt-and-pepper noise, extra shake
    lgmd_sim.parallel    independent jobs on a local pool or on Ray
    lgmd_sim.speed       speed benchmarks (`lgmd-sim speed`)
    lgmd_sim.cli         the `lgmd-sim` command

Importing lgmd_sim registers every scenario of the catalogue as `lgmd_sim/<Name>-v0`.
"""

__version__ = "0.1.0"

from lgmd_sim.envs.catalogue import register_all as _register_all

_register_all()  # entry-point strings only: no MuJoCo import until an env is made
