"""benchmarks/paper_trial_speed.py's profile: its parts are read from a profile by file and function."""

from types import SimpleNamespace

import pytest
from script_helpers import load_script

pytestmark = pytest.mark.integration  # a lab check (benchmarks/paper_trial_speed.py): the integration tier

bench = load_script("benchmarks/paper_trial_speed.py")


def test_each_part_is_its_functions_cumulative_time_or_a_builtins_own_time():
    stats = SimpleNamespace(
        stats={
            ("/repo/antmaze_hirl/dagger/high_level_policy.py", 400, "fit"): (10, 10, 0.5, 27.5, {}),
            ("/repo/antmaze_hirl/experiments/outcomes.py", 37, "play_mazes"): (2, 2, 0.1, 34.0, {}),
            ("~", 0, "<built-in method mujoco._functions.mj_step>"): (900, 900, 17.0, 17.0, {}),
            ("/elsewhere/module.py", 1, "fit"): (1, 1, 9.0, 9.0, {}),  # another fit: not the learner's
        }
    )
    assert bench.profile_parts(stats) == {
        "evaluations": 34.0,
        "learner_gradient_steps": 27.5,
        "physics_mj_step": 17.0,
        "low_level_network": 0.0,
    }


def test_a_profile_is_never_written_over_the_committed_timings(capsys):
    with pytest.raises(SystemExit) as raised:
        bench.main(["--profile", "--episodes", "1"])
    assert raised.value.code == 2 and "give --out" in capsys.readouterr().err
