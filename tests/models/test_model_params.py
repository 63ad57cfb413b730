"""Model parameters: values that would hold the potential at a constant 0.5 are refused
with the parameter's name, and every parameter's source says where it is documented."""

from __future__ import annotations

import pytest

from lgmd_sim import models
from lgmd_sim.signals import stimuli


@pytest.mark.parametrize(("name", "params", "field"), [
    ("lgmd2", {"tau_sfa": 0.0}, "tau_sfa"),  # SFA decay tau / (tau + dt) = 0
    ("f_on", {"tau_sfa": 0.0}, "tau_sfa"),
    ("f_off", {"tau_sfa": 0}, "tau_sfa"),
    ("lgmd1", {"t_ffi": 0.0}, "t_ffi"),  # mean |P| >= 0 always: FFI rests K at 0.5
    ("lgmd2", {"global_ffi_base": 0.0}, "global_ffi_base"),  # the global FFI always on
    ("f_on", {"global_ffi_base": 0.0, "global_ffi_gain": 0.0}, "global_ffi_base"),
    ("feedback", {"eps1": 0.0, "eps2": 0.0}, "eps1"),  # S = 0 everywhere
])
def test_values_that_flatten_the_potential_are_refused_by_name(name, params, field):
    with pytest.raises(ValueError, match=field) as err:
        models.make(name, **params)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("name", "params"), [
    ("feedback", {"eps1": 0.0}), ("lgmd2", {"tau_pm": 0.0}),
    ("lgmd1", {"t_ffi": 10.0}), ("f_on", {"global_ffi_base": None}),
])
def test_their_neighbours_still_respond_to_an_approach(name, params):
    frames = stimuli.approaching((48, 64), look=stimuli.Look(background="texture")).frames
    m = models.make(name, **params)
    assert max(m.step(f).potential for f in frames) > 0.6
