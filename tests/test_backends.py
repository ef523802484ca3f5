"""Backends without Ray: settings refused with one line, the missing extra named, a worker's check, errors."""

import operator
import re
import sys

import pytest

from antmaze_hirl.cli import main
from antmaze_hirl.experiments import ExperimentConfig, run_experiment
from antmaze_hirl.experiments.backends import Backend, run_tasks
from antmaze_hirl.experiments.runner import check_worker, worker_identity


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"kind": "slurm"}, "backend must be one of ['serial', 'processes', 'ray'], got 'slurm'"),
        ({"kind": "serial", "jobs": 2}, "the serial backend runs one task at a time, got jobs=2"),
        ({"kind": "processes", "jobs": 0}, "jobs must be an int >= 1, got 0"),
        ({"kind": "ray", "cpus_per_task": 1.5}, "cpus_per_task must be an int >= 1, got 1.5"),
        ({"kind": "processes", "address": "head-node:6379"}, "an address is for the ray backend only, got address"),
        ({"kind": "ray", "max_retries": -1}, "max_retries must be an int >= 0, got -1"),
    ],
)
def test_bad_backend_settings_are_refused_naming_the_value(settings, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        Backend(**settings)


def test_the_ray_backend_without_ray_names_the_extra_before_writing(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` meets where the extra is not installed
    with pytest.raises(ValueError, match=r"needs Ray, which is not installed here: pip install -e \.\[ray\]"):
        run_experiment(["dagger"], 1, ExperimentConfig(), tmp_path / "api", backend="ray")
    assert not (tmp_path / "api").exists()
    with pytest.raises(SystemExit) as exit_info:
        main(["experiment", "--out", str(tmp_path / "cli"), "--backend", "ray"])
    assert exit_info.value.code == 2
    [line] = capsys.readouterr().err.splitlines()
    assert "needs Ray, which is not installed here: pip install -e .[ray]" in line


def test_a_worker_refuses_another_low_level_or_code():
    expected = worker_identity("point")
    check_worker("point", None, expected)  # the same process: the same policy and sources
    with pytest.raises(ValueError, match=r"has low_level sha256:[0-9a-f]{16}, the driver sha256:0{16}: install"):
        check_worker("point", None, {**expected, "low_level": "sha256:" + "0" * 16})
    with pytest.raises(ValueError, match=r"has source_sha256 [0-9a-f]{64}, the driver 1{64}"):
        check_worker("point", None, {**expected, "source_sha256": "1" * 64})


@pytest.mark.integration
@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_a_failing_task_is_raised_as_itself_after_the_others_finish(kind):
    results = {}
    tasks = {"ok": (6, 3), "fails": (1, 0)}
    with pytest.raises(ZeroDivisionError):
        run_tasks(operator.truediv, tasks, Backend(kind, jobs=1 if kind == "serial" else 2), results.__setitem__)
    assert results == {"ok": 2.0}
