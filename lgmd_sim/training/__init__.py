"""Training avoidance policies with stable-baselines3 (the 'rl' extra), CleanRL-style: each
step of the job in a module of its own, read top to bottom.

- `lgmd_sim.training.envs`: the training VecEnv, observing as `lgmd_sim.policies.observe`
  (a trained policy on disk and what it sees live in `lgmd_sim.policies`, below the
  controllers that drive with it);
- `lgmd_sim.training.algos`: the algorithms' hyperparameters per observation kind;
- `lgmd_sim.training.callbacks`: progress bar, collision rate, validation, checkpoints;
- `lgmd_sim.training.curve`: the learning curve from the logs;
- `lgmd_sim.training.run`: `lgmd-sim train`, its options in `lgmd_sim.training.config`
  and its phases (DAgger, value warm-up, RL through a curriculum) in
  `lgmd_sim.training.phases`; `lgmd_sim.training.evaluate`: `lgmd-sim bench closed-loop
  --policies`.

A trained policy drives like any controller (`lgmd_sim.controllers.Policy`), so the
closed-loop benchmark compares it with the hand-made ones on the same seeds.
"""
