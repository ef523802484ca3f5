"""The demo's lockstep path plays the demo's own episodes; scripts/demo_success.py records the mode."""

import pytest
from script_helpers import load_script

from antmaze_hirl.demo import lockstep_outcomes, serial_outcomes


def test_lockstep_gives_the_demos_outcomes_on_the_point(capsys):
    # The demo itself (fresh env, picture) seed after seed against both mazes at once on copies of its env.
    serial = serial_outcomes("point", 2)
    serial_lines = capsys.readouterr().out.splitlines()
    lockstep = lockstep_outcomes("point", 2, num_envs=2)
    assert lockstep == serial and set(serial) <= {"success", "flip", "timeout", "ended"}
    assert capsys.readouterr().out.splitlines() == serial_lines  # same subgoals and steps, seed by seed


@pytest.mark.integration  # a lab check (scripts/demo_success.py)
def test_measure_records_the_mode():
    demo_success = load_script("scripts/demo_success.py")
    figures = demo_success.measure("point", 1, num_envs=2)
    assert figures["num_envs"] == 2 and figures["episodes"] == 1
    with pytest.raises(ValueError, match="unknown body 'cat'"):
        lockstep_outcomes("cat", 2, num_envs=2)
