"""Signals: what the models see and what their outputs are measured by.

- `lgmd_sim.signals.stimuli`: synthetic stimuli (the classic LGMD characterisation set);
- `lgmd_sim.signals.video`: a user's video read as grey frames, and frames written as video;
- `lgmd_sim.signals.noise`: sensor noise added to frames;
- `lgmd_sim.signals.metrics`: the paper's measures (ISI, MpSI, SI) and alarm events.
"""
