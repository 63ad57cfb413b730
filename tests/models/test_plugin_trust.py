"""A plug-in model is the researcher's code, run by every command: whatever it does wrong
(writing into its input frames, potentials that are NaN or out of range, raising in its
constructor or its step, calling sys.exit, a parameter named like one of the base's) ends
the command with one line naming the plug-in, exit status 2, and nothing left behind; and
no plug-in can change what the other models of a run see."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from lgmd_sim import models
from lgmd_sim.models import ModelCheckError, PluginError, check_model

# the faulty plug-ins are tests/plugins/hostile.py
pytestmark = pytest.mark.usefixtures("test_plugins_on_path")


# --- one frame for every model -----------------------------------------------------------


def test_a_plug_in_cannot_change_the_frame_every_model_reads():
    frame = np.random.default_rng(0).integers(0, 256, (24, 32), np.uint8)
    kept = frame.copy()
    model = models.make("hostile:Mutating")
    with pytest.raises(PluginError, match="writes into its input frames, which are read-only"):
        model.step(frame)
    np.testing.assert_array_equal(frame, kept)
    for name in models.available():  # the built-ins read the same frames and keep to them
        models.make(name, n_streams=2).step(np.stack([frame, frame]))
    np.testing.assert_array_equal(frame, kept)


def test_check_model_names_the_mutation():
    with pytest.raises(ModelCheckError) as exc:
        check_model("hostile:Mutating")
    assert "potentials: step_batch: it writes into its input frames" in str(exc.value)
    assert "unseeded random numbers" not in str(exc.value)


# --- potentials, in every command --------------------------------------------------------


# --- a plug-in's own errors --------------------------------------------------------------




def test_a_plug_in_s_error_crosses_from_a_worker_whole():
    error = PluginError("hostile:LateBoom", "step_batch", "raised RuntimeError: boom late")
    again = pickle.loads(pickle.dumps(error))
    assert isinstance(again, PluginError) and str(again) == str(error) == (
        "plug-in model hostile:LateBoom: step_batch: raised RuntimeError: boom late")


def test_lgmd_sim_s_own_refusals_pass_through_a_plug_in_unchanged():
    with pytest.raises(ValueError) as exc:
        models.make("lgmd_plug:NoMaps", preset="plain+image")
    assert not isinstance(exc.value, PluginError)
    assert str(exc.value).startswith("nomaps lists no state maps")


# --- the base's parameter names ----------------------------------------------------------


def test_a_parameter_named_like_the_base_s_is_refused_naming_it():
    with pytest.raises(ModelCheckError) as exc:
        check_model("hostile:Shadow")
    text = str(exc.value)
    assert "parameters: parameter gain is the base class's" in text
    for name in models.RESERVED_PARAMETERS:
        assert name in text
    assert "must be a finite number" not in text
    with pytest.raises(PluginError, match="parameter gain is the base class's"):
        models.make("hostile:Shadow")  # else its gain of 2.0 would turn the front end on


@pytest.mark.usefixtures("examples_on_path")
def test_the_reserved_names_are_the_base_s_but_threshold():
    assert set(models.RESERVED_PARAMETERS) == {
        "stabilize", "fovy", "gain", "alarm_frames", "alarm_rising", "working_height"}
    eta = json.dumps(check_model("eta_lgmd:EtaLGMD"))  # redeclares threshold: allowed
    assert "parameters" in eta
