"""antmaze_lab.flip_warning: the tilt reflex, the flip lead and the reflex specs."""

import numpy as np
import pytest

from antmaze_lab import flip_warning

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.flip_warning): the integration tier


def ant_observation(roll_degrees):
    """An ant goal observation whose torso is rolled about x by ``roll_degrees``."""
    body = np.zeros(27)
    half = np.radians(roll_degrees) / 2
    body[0], body[1:5] = 0.6, [np.cos(half), np.sin(half), 0.0, 0.0]
    return {"observation": body, "achieved_goal": np.zeros(2), "desired_goal": np.ones(2)}


def test_tilt_reflex_scales_actions_only_below_its_threshold_and_records_uprightness():
    reflex = flip_warning.TiltReflex(lambda obs: np.full(8, 0.8), threshold=0.5, scale=0.25)
    np.testing.assert_allclose(reflex(ant_observation(30)), 0.8)  # cos 30 = 0.87: above 0.5, untouched
    np.testing.assert_allclose(reflex(ant_observation(70)), 0.2)  # cos 70 = 0.34: scaled
    np.testing.assert_allclose(reflex.trace, [np.cos(np.radians(30)), np.cos(np.radians(70))])
    assert reflex.acted == 1
    reflex.reset()
    assert reflex.trace == []
    recorder = flip_warning.TiltReflex(lambda obs: np.ones(8))  # threshold -1: never acts
    np.testing.assert_allclose(recorder(ant_observation(179)), 1.0)
    assert recorder.acted == 0


@pytest.mark.parametrize(("kwargs", "message"), [({"threshold": 1.5}, "threshold"), ({"scale": -0.1}, "scale")])
def test_tilt_reflex_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=f"reflex {message} must lie in"):
        flip_warning.TiltReflex(lambda obs: np.zeros(8), **kwargs)


def test_flip_lead_counts_steps_since_the_last_step_at_or_above_the_threshold():
    trace = np.array([0.9, 0.95, 0.7, 0.85, 0.6, 0.4, 0.1])
    assert flip_warning.flip_lead(trace, 0.8) == 3  # last >= 0.8 at index 3, flip after index 6
    assert flip_warning.flip_lead(trace, 0.9) == 5
    assert flip_warning.flip_lead(trace, 0.05) == 0
    assert flip_warning.flip_lead(trace, 0.99) == 7  # never that upright: the whole trace
    figures = flip_warning.warning_figures(["flip", "success"], [trace, [0.9, 0.75, 0.95]], [0.8])["0.8"]
    assert (figures["lead_steps_median"], figures["non_flip_steps_below"], figures["non_flip_steps"]) == (3.0, 1, 3)


def test_parse_reflexes_reads_k_at_u_and_names_a_bad_entry():
    assert flip_warning.parse_reflexes("0@0.8, 0.3@0.7") == [(0.0, 0.8), (0.3, 0.7)]
    assert flip_warning.parse_reflexes("") == []
    with pytest.raises(ValueError, match=r"reflex '0.3' is not K@U"):
        flip_warning.parse_reflexes("0@0.8,0.3")
    with pytest.raises(ValueError, match=r"reflex '2@0.8': K must lie in \[0, 1\]"):
        flip_warning.parse_reflexes("2@0.8")
