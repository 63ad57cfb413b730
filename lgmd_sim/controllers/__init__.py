"""Controllers: what drives the camera's carrier, frame by frame.

One small interface: ``reset()`` at the start of an episode, ``act(obs, info) -> action``
on every frame (the action for `JitterEnv.step`: (v, omega) in [-1, 1]). Each controller
documents what it reads of the observation and of ``info`` (the ground truth).

>>> from lgmd_sim.controllers import Straight, rollout
>>> for step in rollout(env, Straight(), seed=0):
...     step.obs["frame"], step.info["threat_ttc"], step.action
"""

from lgmd_sim.controllers.base import Controller, Step, rollout
from lgmd_sim.controllers.straight import Straight, StraightParams

__all__ = ["Controller", "Step", "Straight", "StraightParams", "rollout"]
