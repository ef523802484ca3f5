"""scripts/protocol2_rerun.sh: the checkpoint that carries the background rerun across fresh machines."""

import os
import subprocess
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration  # a lab check (scripts/protocol2_rerun.sh): the integration tier

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "protocol2_rerun.sh"


def run(tmp_path, *args):
    env = {**os.environ, "PROTOCOL2_WORK": str(tmp_path / "work"), "PROTOCOL2_CHECKPOINTS": str(tmp_path / "ckpt")}
    return subprocess.run(["bash", str(SCRIPT), *args], env=env, capture_output=True, text=True, check=False)


def test_a_checkpoint_restores_the_finished_trials_byte_for_byte(tmp_path):
    folder = tmp_path / "work" / "point_p2_36dafd8"
    (folder / "trials").mkdir(parents=True)
    files = {
        "config.json": '{"body": "point"}',
        "provenance.json": '{"git_commit": "36dafd8"}',
        "trials/dagger_seed0.csv": "method,seed\ndagger,0\n",
        "trials/dagger_seed0.json": '{"seconds": 1.0}',
    }
    for name, text in files.items():
        (folder / name).write_text(text)
    (folder / "summary.json").write_text("{}")  # rewritten from the trials: not packed
    packed = run(tmp_path, "checkpoint", "point")
    assert packed.returncode == 0, packed.stderr
    assert "packed 1 trials of point" in packed.stdout
    for path in sorted(folder.rglob("*"), reverse=True):
        path.unlink() if path.is_file() else path.rmdir()
    restored = run(tmp_path, "restore", "point")
    assert restored.returncode == 0, restored.stderr
    assert "restored 1 trials of point" in restored.stdout
    assert {str(p.relative_to(folder)): p.read_text() for p in folder.rglob("*") if p.is_file()} == files
    assert "point: 1 of 70 trials" in run(tmp_path, "status").stdout


def test_restore_leaves_a_folder_that_already_has_trials(tmp_path):
    (tmp_path / "ckpt").mkdir()
    trials = tmp_path / "work" / "ant_p2_36dafd8" / "trials"
    trials.mkdir(parents=True)
    (trials / "dagger_seed0.json").write_text("{}")
    assert run(tmp_path, "restore", "ant").stdout == ""


@pytest.mark.parametrize(
    ("args", "message"),
    [(["checkpoint", "car"], "BODY must be point or ant, got 'car'"), (["fly"], "got 'fly'")],
)
def test_a_bad_body_or_command_is_one_line_naming_it(tmp_path, args, message):
    result = run(tmp_path, *args)
    assert result.returncode == 2
    assert message in result.stderr and result.stderr.count("\n") == 1


def test_checkpoint_without_trials_fails_naming_the_folder(tmp_path):
    result = run(tmp_path, "checkpoint", "ant")
    assert result.returncode == 1
    assert "no trials in" in result.stderr and "ant_p2_36dafd8" in result.stderr


def test_start_refuses_while_the_bodys_rerun_is_running(tmp_path):
    (tmp_path / "work").mkdir()
    alive = subprocess.Popen(["sleep", "30"])
    try:
        (tmp_path / "work" / "point.pid").write_text(str(alive.pid))
        result = run(tmp_path, "start", "point")
        assert result.returncode == 1
        assert f"the point rerun is already running (pid {alive.pid})" in result.stderr
    finally:
        alive.kill()


@pytest.mark.parametrize("jobs", ["0", "two", "-1", "100"])
def test_start_refuses_a_bad_job_count_before_touching_anything(tmp_path, jobs):
    env = {
        **os.environ,
        "PROTOCOL2_WORK": str(tmp_path / "work"),
        "PROTOCOL2_CHECKPOINTS": str(tmp_path / "ckpt"),
        "PROTOCOL2_CLONE": str(tmp_path / "clone"),
        "PROTOCOL2_JOBS": jobs,
    }
    result = subprocess.run(["bash", str(SCRIPT), "start", "ant"], env=env, capture_output=True, text=True, check=False)
    assert result.returncode == 2
    assert result.stderr == f"PROTOCOL2_JOBS must be an integer from 1 to 99, got '{jobs}'\n"
    assert not (tmp_path / "clone").exists() and not (tmp_path / "work").exists()


def test_start_records_the_experiments_own_pid_and_passes_the_job_count(tmp_path):
    """The pid file is what stops a second start, so it must name the live experiment, not a launcher."""
    repo = SCRIPT.parents[1]
    commit = next(line for line in SCRIPT.read_text().splitlines() if line.startswith("COMMIT=")).split("=")[1]
    if subprocess.run(["git", "-C", str(repo), "cat-file", "-e", commit], capture_output=True).returncode != 0:
        pytest.skip(f"this checkout lacks the rerun's commit {commit[:7]} (a shallow clone)")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", "--shared", "--no-checkout", str(repo), str(clone)], check=True)
    main = tmp_path / "main"  # a stand-in main checkout whose venv python only sleeps
    (main / "scripts").mkdir(parents=True)
    (main / "scripts" / "protocol2_rerun.sh").write_text(SCRIPT.read_text())
    subprocess.run(["git", "-C", str(clone), "checkout", "-q", commit], check=True)  # before the timed start
    (main / ".venv" / "bin").mkdir(parents=True)
    fake = main / ".venv" / "bin" / "python"
    fake.write_text('#!/bin/bash\necho "args: $*"\nexec sleep 30\n')
    fake.chmod(0o755)
    work = tmp_path / "work"
    env = {**os.environ, "PROTOCOL2_WORK": str(work), "PROTOCOL2_CLONE": str(clone), "PROTOCOL2_JOBS": "2"}
    env["PROTOCOL2_CHECKPOINTS"] = str(tmp_path / "ckpt")
    start = [str(main / "scripts" / "protocol2_rerun.sh"), "start", "ant"]
    # capture_output pipes stdout: start must return without waiting on the (30 s) experiment behind it.
    first = subprocess.run(["bash", *start], env=env, capture_output=True, text=True, check=False, timeout=20)
    assert first.returncode == 0, first.stderr
    pid = int((work / "ant.pid").read_text())
    try:
        assert Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")[:2] == [b"sleep", b"30"]
        second = subprocess.run(["bash", *start], env=env, capture_output=True, text=True, check=False)
        assert second.returncode == 1
        assert f"the ant rerun is already running (pid {pid})" in second.stderr
    finally:
        os.kill(pid, 9)
    assert "--backend processes --jobs 2 --cpus-per-trial 1" in (work / "ant.log").read_text()
