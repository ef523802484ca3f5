"""The examples run end to end, with tiny settings, as a user would start them (a fresh interpreter each)."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[1]


def run_example(name, *args, cwd):
    """Runs ``examples/<name>`` on this checkout's package; returns its stdout (stderr too on failure)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / name), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def test_dagger_point_example_trains_saves_and_draws(tmp_path):
    out = run_example("dagger_point.py", "--episodes", "2", "--eval-episodes", "2", "--out", "smoke", cwd=tmp_path)
    cost = re.search(r"expert labels: (\d+) over 2 episodes", out)
    assert cost is not None and int(cost.group(1)) >= 2, out
    assert re.search(r"learner-only: \{.*'success_rate': ", out), out
    assert (tmp_path / "smoke" / "high_level_point.zip").stat().st_size > 0
    assert (tmp_path / "smoke" / "dagger_point.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("timesteps", "progress"),
    [
        ("250", r"Using cpu device"),  # verbose: SB3 talks to a pipe
        # Long enough for SB3's first table (every 20 episodes of 50 steps): the progress a log shows.
        pytest.param("1000", r"\|\s+total_timesteps\s+\|\s+1000\s+\|", marks=pytest.mark.slow),
    ],
)
def test_low_level_sac_example_trains_and_logs_its_progress_to_a_pipe(tmp_path, timesteps, progress):
    args = ("--timesteps", timesteps, "--reach-episodes", "2", "--maze-episodes", "1")
    out = run_example("low_level_sac.py", *args, cwd=tmp_path)
    assert re.search(progress, out), out
    assert re.search(r"reach: \{.*'success_rate': ", out), out
    assert re.search(r"oracle \+ SAC low level: \{.*'success_rate': ", out), out
