"""Synthetic stimuli: the classic LGMD characterisation set, seeded, as uint8 grey frames.

- `lgmd_sim.signals.stimuli.objects`: an object (a dark or light square or disc, as its `Look`
  says) approaching, receding, crossing the view, turning or at rest in a pinhole-camera
  world,
  drawn with exact area coverage at its edges;
- `lgmd_sim.signals.stimuli.fields`: full-field stimuli without an object (grating, flicker);
- `lgmd_sim.signals.stimuli.clip`: the `Stimulus` they all return, and `jittered`, any of them
  seen by a shaking camera.

>>> from lgmd_sim.signals import stimuli
>>> s = stimuli.approaching(look=stimuli.Look(polarity="dark"))   # looming to collision
>>> s.frames.shape, s.collision_frame                  # ((51, 120, 160), 50)
>>> shaken = stimuli.jittered(s, level=1.0, seed=3)    # the same, seen by a shaking camera
"""

from lgmd_sim.signals.stimuli.clip import Stimulus, jittered
from lgmd_sim.signals.stimuli.fields import flicker, grating
from lgmd_sim.signals.stimuli.objects import (
    Look,
    approaching,
    receding,
    rotating,
    static,
    translating,
)

__all__ = [
    "Look",
    "Stimulus",
    "approaching",
    "flicker",
    "grating",
    "jittered",
    "receding",
    "rotating",
    "static",
    "translating",
]
