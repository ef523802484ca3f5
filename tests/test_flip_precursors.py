"""antmaze_lab.flip_precursors: the summary of per-step records, on crafted records with known answers."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from antmaze_lab import flip_precursors

pytestmark = pytest.mark.integration  # lab code, run as its command line

ROOT = Path(__file__).resolve().parents[1]


def episode(seed, uprightness, contacts=(), wall_m=2.0):
    """Rows of one crafted episode: ``uprightness`` per step, a leg-wall contact at each step in ``contacts``."""
    columns = {name: index for index, name in enumerate(flip_precursors.COLUMNS)}
    rows = np.zeros((len(uprightness), len(columns)))
    rows[:, columns["ep"]] = seed
    rows[:, columns["t"]] = np.arange(len(uprightness))
    rows[:, columns["since"]] = np.arange(len(uprightness)) % 15 + 1
    rows[:, columns["up"]] = uprightness
    rows[:, columns["vx"]] = rows[:, columns["offx"]] = 1.0  # walking straight at its subgoal, 1 m/s
    rows[:, [columns[f"a{k}"] for k in range(8)]] = 0.25
    rows[list(contacts), columns["wallc"]] = 1
    rows[:, columns["walld"]] = wall_m
    return rows


def falling(upright_steps, fall_steps=9):
    """Uprightness 1 for ``upright_steps`` steps, then a fall of ``fall_steps`` steps below 0.9 to 0.05."""
    return np.r_[np.ones(upright_steps), np.linspace(0.85, 0.05, fall_steps)]


def write_record(path, episodes, outcomes):
    """A record as ``record`` writes it (without settings, as session 29's probe did), with its episodes
    interleaved as lockstep play interleaves them."""
    rows = np.concatenate(episodes)
    rows = rows[np.argsort(rows[:, 1], kind="stable")]  # step-major: the summary must sort them back
    np.savez_compressed(
        path,
        rows=rows,
        cols=np.array(flip_precursors.COLUMNS),
        seeds=np.arange(len(episodes)),
        outcomes=np.array(outcomes),
    )
    return path


def summarise(*argv):
    return subprocess.run(
        [sys.executable, "-m", "antmaze_lab.flip_precursors", "summarise", *map(str, argv)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


@pytest.fixture
def crafted(tmp_path):
    """Three episodes: a flip 10 steps after a wall contact, a calm success, and a flip whose last contact is
    30 steps before its onset, after a dip to 0.85 that recovers."""
    wall_led = falling(31)  # onset (last step >= 0.9) at step 30, flip at step 39
    calm = np.ones(100)
    open_space = falling(51)  # onset at step 50, flip at step 59
    open_space[10] = 0.85  # a dip: the onset is the *last* step >= 0.9, not the first below
    episodes = [episode(0, wall_led, contacts=[20]), episode(1, calm), episode(2, open_space, contacts=[20])]
    return write_record(tmp_path / "run.npz", episodes, ["flip", "success", "flip"])


def test_summary_counts_a_flip_ten_steps_after_a_wall_contact_as_wall_led(crafted, tmp_path):
    out = tmp_path / "summary.json"
    result = summarise(f"run={crafted}", "--out", out, "--describe", "run=crafted")
    assert result.returncode == 0, result.stderr
    run = json.loads(out.read_text())["runs"]["run"]
    assert run["low_level"] == "crafted"
    assert run["outcomes"] == {"flip": 2, "success": 1}
    assert run["low_level_steps"] == 40 + 100 + 60
    assert run["onset_to_flip_steps"] == {"median": 9.0, "min": 9, "max": 9}
    assert run["wall_contact_in_20_steps_before_onset"] == "1 of 2"
    # After a contact: steps 21-30 of the first flip (to its onset) and 21-40 of the other (20 steps each).
    assert run["steps_after_a_wall_contact"] == 10 + 20
    assert run["onset_hazard_per_10k_steps_after_a_wall_contact"] == round(1 / 30 * 1e4, 2)
    assert run["onset_hazard_per_10k_steps_otherwise"] == round(1 / (21 + 100 + 31) * 1e4, 2)
    assert run["onset_hazard_per_10k_by_torso_to_wall_m"]["1.5-99"] == f"2 / 182 = {2 / 182 * 1e4:.2f}"
    assert run["steps_since_subgoal_at_onset"] == [30 % 15 + 1, 50 % 15 + 1]
    assert run["mean_abs_action_20_steps_before_onset_median"] == 0.25
    assert run["speed_m_s_20_steps_before_onset_median"] == 1.0
    assert run["velocity_to_subgoal_deg_non_flip_median"] == 0.0
    assert run["non_flip_dips_below_uprightness"] == {"0.8": 0, "0.7": 0, "0.6": 0}


def test_summary_compares_runs_on_the_same_mazes(crafted, tmp_path):
    out = tmp_path / "summary.json"
    result = summarise(f"a={crafted}", f"b={crafted}", "--out", out, "--compare", "b:a", "--pool", "both=a+b:b")
    assert result.returncode == 0, result.stderr
    paired = json.loads(out.read_text())["paired"]
    assert paired["b vs a"] == {
        "flips": "2 vs 2",
        "equal_flip_rate_exact_conditional_p": 1.0,
        "success_only_a": 0,
        "success_only_b": 0,
        "mcnemar_p": 1.0,
        "flipping_mazes_shared": 2,
    }
    assert paired["both"]["flips"] == "4 / 400 vs 2 / 200"


def test_summary_of_a_missing_file_exits_2_with_one_line(tmp_path):
    result = summarise(f"run={tmp_path / 'absent.npz'}", "--out", tmp_path / "summary.json")
    assert result.returncode == 2
    assert result.stderr == f"error: no record at {tmp_path / 'absent.npz'}\n"
    assert not (tmp_path / "summary.json").exists()


def test_summary_of_a_file_that_is_not_a_record_exits_2_with_one_line(tmp_path):
    text = tmp_path / "notes.npz"
    text.write_text("not a record\n")
    result = summarise(f"run={text}", "--out", tmp_path / "summary.json")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and f"{text} is not a flip_precursors record" in result.stderr
    np.savez(tmp_path / "other.npz", rows=np.zeros((2, 3)))  # an npz, but not a record
    result = summarise(f"run={tmp_path / 'other.npz'}", "--out", tmp_path / "summary.json")
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run.npz"], "run 'run.npz' is not LEFT=RIGHT"),
        (["run=RUN", "--compare", "run:ghost"], "not a run given as NAME=RUN.npz: ghost"),
        (["run=RUN", "--pool", "label=run"], "--pool 'run' is not LEFT:RIGHT"),
    ],
)
def test_summary_names_bad_run_specs(crafted, tmp_path, argv, message):
    argv = [str(crafted) if arg == "RUN" else arg.replace("=RUN", f"={crafted}") for arg in argv]
    result = summarise(*argv, "--out", tmp_path / "summary.json")
    assert result.returncode == 2
    assert result.stderr == f"error: {message}\n"


def test_parse_tilt_damping_reads_three_numbers_and_names_a_bad_text():
    assert flip_precursors.parse_tilt_damping("0.8,0.6,0.3") == (0.8, 0.6, 0.3)
    with pytest.raises(ValueError, match=r"--tilt-damping '0.8,0.6' is not U,L,K"):
        flip_precursors.parse_tilt_damping("0.8,0.6")
