import dataclasses
import json
import math

import pytest
import torch as th

from antmaze_hirl.cli import main
from antmaze_hirl.experiments import ExperimentConfig, cost_to_reach, run_experiment, summarise

TINY = ExperimentConfig(
    body="point", episodes=3, eval_every=2, eval_episodes=2, final_eval_episodes=3, maze_size=3, gradient_steps=5
)


def row(method, seed, episode, cost, eval_success=math.nan, attempts=4):
    return {
        "method": method,
        "seed": seed,
        "episode": episode,
        "success": True,
        "expert_cost": 5,
        "cumulative_expert_cost": cost,
        "attempts": attempts,
        "eval_success": eval_success,
    }


def test_cost_to_reach_uses_the_first_evaluation_at_target():
    trial = [row("a", 0, 0, 5), row("a", 0, 1, 10, 0.5), row("a", 0, 2, 15, 0.6), row("a", 0, 3, 20, 0.9)]
    assert cost_to_reach(trial) == 15
    assert cost_to_reach(trial[:2]) is None


def test_summary_over_seeds():
    rows = [row("a", 0, 0, 5, 0.7), row("a", 1, 0, 8, 0.2), row("a", 2, 0, 6, 0.4), row("b", 0, 0, 3, 0.1, attempts=9)]
    summary = summarise(rows, ["a", "b"])
    assert summary["a"]["final_success"] == {"median": 0.4, "min": 0.2, "max": 0.7}
    assert summary["a"]["cost_to_60_percent"] == {"median": 5.0, "seeds_reached": 1}
    assert summary["b"]["mean_attempts_per_episode"] == 9
    assert summary["b"]["cost_to_60_percent"]["median"] is None
    assert summarise(rows, ["c"]) == {"c": {"seeds": 0}}


def test_experiment_writes_tables_and_resumes_per_trial(tmp_path):
    summary = run_experiment(["dagger", "reward"], 2, TINY, tmp_path, progress_bar=False)
    assert set(summary["methods"]) == {"dagger", "reward"}
    trial = tmp_path / "trials" / "dagger_seed1.csv"
    lines = (tmp_path / "episodes.csv").read_text().splitlines()
    assert lines[0].startswith("method,seed,episode,success,expert_cost,cumulative_expert_cost")
    assert len(lines) == 1 + 2 * 2 * 3
    assert (tmp_path / "panels.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / "summary.json").read_text())["methods"]["dagger"]["seeds"] == 2
    before = trial.stat().st_mtime_ns
    trial.with_suffix(".json").unlink()
    (tmp_path / "trials" / "reward_seed1.csv").unlink()  # as if interrupted during that trial
    run_experiment(["dagger", "reward"], 2, TINY, tmp_path, progress_bar=False)
    assert trial.stat().st_mtime_ns == before, "finished trials are not run again"
    assert (tmp_path / "trials" / "reward_seed1.csv").exists()


def test_parallel_trials_give_the_same_numbers_as_one_job(tmp_path):
    serial = run_experiment(["dagger", "reward"], 2, TINY, tmp_path / "serial", progress_bar=False)
    parallel = run_experiment(["dagger", "reward"], 2, TINY, tmp_path / "parallel", progress_bar=False, jobs=2)
    assert parallel["methods"] == serial["methods"]
    assert (tmp_path / "parallel" / "episodes.csv").read_text() == (tmp_path / "serial" / "episodes.csv").read_text()
    with pytest.raises(ValueError, match="jobs must be >= 1, got 0"):
        run_experiment(["dagger"], 1, TINY, tmp_path / "other", progress_bar=False, jobs=0)


def test_experiment_refuses_mixed_settings_and_unknown_methods(tmp_path):
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    with pytest.raises(ValueError, match="holds results made with"):
        run_experiment(["dagger"], 1, ExperimentConfig(body="point", episodes=4), tmp_path, progress_bar=False)
    with pytest.raises(ValueError, match="unknown method 'aggrevate'"):
        run_experiment(["aggrevate"], 1, TINY, tmp_path / "other", progress_bar=False)
    with pytest.raises(ValueError, match="expert_max_distance must be > 0 metres, got -1"):
        ExperimentConfig(expert_max_distance=-1.0)


def test_experiment_refuses_results_made_with_another_low_level(tmp_path):
    from antmaze_hirl.envs.controllers import PointGoToController
    from antmaze_hirl.sb3_ext.loading import load_low_level
    from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

    summary = run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    shipped = summary["config"]["low_level"]
    assert shipped.startswith("sha256:") and json.loads((tmp_path / "config.json").read_text())["low_level"] == shipped
    # The same weights loaded again are the same low level; other weights or a scripted controller are not.
    run_experiment(["dagger"], 1, TINY, tmp_path, low_level=load_low_level("point"), progress_bar=False)
    retrained = load_low_level("point", shipped_policy_path("point"))
    with th.no_grad():
        next(retrained.policy.parameters()).add_(1e-3)
    for other in (retrained, PointGoToController()):
        with pytest.raises(ValueError, match=f"made with low-level policy {shipped}, not"):
            run_experiment(["dagger"], 1, TINY, tmp_path, low_level=other, progress_bar=False)


def test_results_written_before_a_setting_existed_still_resume(tmp_path):
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)
    config_file = tmp_path / "config.json"
    saved = json.loads(config_file.read_text())
    del saved["expert_max_distance"]  # as written by an older version
    config_file.write_text(json.dumps(saved))
    run_experiment(["dagger"], 1, TINY, tmp_path, progress_bar=False)  # the new setting at its default matches
    with pytest.raises(ValueError, match="holds results made with"):
        run_experiment(["dagger"], 1, dataclasses.replace(TINY, expert_max_distance=0.5), tmp_path, progress_bar=False)


def test_expert_max_distance_reaches_the_oracle(monkeypatch):
    from antmaze_hirl.experiments import runner

    seen = []
    for_env = runner.PathOracle.for_env

    def recording_for_env(env, **kwargs):
        oracle = for_env(env, **kwargs)
        seen.append(oracle.max_distance)
        return oracle

    monkeypatch.setattr(runner.PathOracle, "for_env", recording_for_env)
    runner.run_trial("dagger", 0, dataclasses.replace(TINY, episodes=1, expert_max_distance=0.5))
    runner.run_trial("dagger", 0, dataclasses.replace(TINY, episodes=1))
    assert seen == [0.5, 1.0]  # the point's cell is 1 m


def test_experiment_cli(tmp_path, capsys):
    args = ["experiment", "--methods", "noise", "--seeds", "1", "--episodes", "2", "--eval-every", "1"]
    args += ["--eval-episodes", "1", "--final-eval-episodes", "2", "--maze-size", "3", "--gradient-steps", "3"]
    assert main([*args, "--out", str(tmp_path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("noise: final success median") and "summary.json" in out
