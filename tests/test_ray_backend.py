"""The ray backend of run_experiment on a local Ray instance: same files as serial, retries, resume, worker check.

Each test runs a 2 methods x 2 seeds point grid of 2 episodes on one shared local Ray instance of 2 CPUs.
"""

import dataclasses
import json
import os
import sys

import pytest

ray = pytest.importorskip("ray", reason="the Ray extra is not installed (pip install -e .[ray])")

from conftest import TINY_PROTOCOL1  # noqa: E402

from antmaze_hirl.envs.controllers import PointGoToController  # noqa: E402
from antmaze_hirl.experiments import run_experiment  # noqa: E402
from antmaze_hirl.experiments import runner as runner_module  # noqa: E402

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

SMALL = dataclasses.replace(
    TINY_PROTOCOL1, episodes=2, eval_every=1, eval_episodes=1, final_eval_episodes=2, gradient_steps=10
)
METHODS = ["dagger", "reward"]
SEEDS = 2


class DiesOnceController(PointGoToController):
    """The scripted point controller; the first worker process to make its 30th step kills itself (once).

    The process that built it (the test, the driver) never dies, so a serial run with it gives the reference.
    """

    def __init__(self, marker):
        super().__init__()
        self.marker = str(marker)
        self.driver = os.getpid()
        self.calls = 0

    def __call__(self, observation):
        self.calls += 1
        if self.calls == 30 and os.getpid() != self.driver:
            try:
                os.close(os.open(self.marker, os.O_CREAT | os.O_EXCL))  # only the first worker here claims it
            except FileExistsError:
                pass
            else:
                os._exit(1)  # as if killed mid-trial: no exception, no cleanup, the worker is gone
        return super().__call__(observation)


@pytest.fixture(scope="module")
def local_ray():
    # Workers cannot import this test module: ship it by value (its controller class) with each task.
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    ray.init(num_cpus=2, include_dashboard=False, logging_level="WARNING")
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    run_experiment(METHODS, SEEDS, SMALL, out, progress_bar=False, backend="serial")
    return out


def comparable_summary(out):
    """summary.json without the trial wall times (they differ from run to run), plus the trials timed."""
    summary = json.loads((out / "summary.json").read_text())
    return json.dumps({**summary, "trial_seconds": sorted(summary["trial_seconds"])}, indent=2)


def trial_files(out):
    return {path.name: path.read_bytes() for path in sorted((out / "trials").glob("*.csv"))}


def test_ray_grid_writes_the_files_of_the_serial_backend(local_ray, serial_run, tmp_path):
    summary = run_experiment(METHODS, SEEDS, SMALL, tmp_path, progress_bar=False, backend="ray", jobs=2)
    assert (tmp_path / "episodes.csv").read_bytes() == (serial_run / "episodes.csv").read_bytes()
    assert (tmp_path / "eval_layouts.csv").read_bytes() == (serial_run / "eval_layouts.csv").read_bytes()
    assert trial_files(tmp_path) == trial_files(serial_run)
    # Everything but the wall times: settings, low level, provenance (same code, this machine), figures.
    assert comparable_summary(tmp_path) == comparable_summary(serial_run)
    assert sorted(summary["trial_seconds"]) == ["dagger_seed0", "dagger_seed1", "reward_seed0", "reward_seed1"]
    assert (tmp_path / "panels.png").read_bytes()[:4] == b"\x89PNG"


def test_a_trial_whose_worker_dies_is_retried_and_the_grid_completes(local_ray, tmp_path):
    marker = tmp_path / "a_worker_died"
    run_experiment(METHODS, SEEDS, SMALL, tmp_path / "serial", low_level=DiesOnceController(marker), progress_bar=False)
    assert not marker.exists()
    # A fresh controller: the one above counted its steps already, and would ship that count to the workers.
    low_level = DiesOnceController(marker)
    run_experiment(METHODS, SEEDS, SMALL, tmp_path / "ray", low_level=low_level, progress_bar=False, backend="ray")
    assert marker.exists(), "no worker died: the test proved nothing"
    assert (tmp_path / "ray" / "episodes.csv").read_bytes() == (tmp_path / "serial" / "episodes.csv").read_bytes()


def test_an_interrupted_ray_grid_resumes_without_redoing_finished_trials(local_ray, serial_run, tmp_path, monkeypatch):
    write_reports = runner_module.write_reports

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # Ctrl-C in the driver just after it saved the first finished trial

    monkeypatch.setattr(runner_module, "write_reports", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run_experiment(METHODS, SEEDS, SMALL, tmp_path, progress_bar=False, backend="ray", jobs=2)
    [finished] = (tmp_path / "trials").glob("*.csv")  # the other trial running then was cancelled
    before = finished.stat().st_mtime_ns
    monkeypatch.setattr(runner_module, "write_reports", write_reports)
    run_experiment(METHODS, SEEDS, SMALL, tmp_path, progress_bar=False, backend="ray", jobs=2)
    assert finished.stat().st_mtime_ns == before, "a finished trial was run again"
    assert (tmp_path / "episodes.csv").read_bytes() == (serial_run / "episodes.csv").read_bytes()


def test_a_worker_with_another_low_level_is_refused(local_ray, tmp_path, monkeypatch):
    # The driver expects other weights than the workers load: as a cluster node with another shipped policy.
    monkeypatch.setattr(runner_module, "low_level_identity", lambda body, low_level=None: "sha256:" + "0" * 16)
    with pytest.raises(ValueError, match=r"worker .* has low_level sha256:[0-9a-f]{16}, the driver sha256:0{16}"):
        run_experiment(METHODS, SEEDS, SMALL, tmp_path, progress_bar=False, backend="ray")
    assert not list((tmp_path / "trials").glob("*.csv")), "a refused worker's trial was saved"


def test_a_trial_needing_more_cpus_than_any_node_has_is_refused(local_ray, tmp_path):
    with pytest.raises(ValueError, match=r"a task's 3 CPUs \(--cpus-per-trial\) are more than any Ray node has \(2\)"):
        run_experiment(METHODS, SEEDS, SMALL, tmp_path, progress_bar=False, backend="ray", cpus_per_trial=3)
