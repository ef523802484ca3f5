"""TensorBoard logs of DAgger training: the scalars at the right steps, and no number of the results changed."""

import csv
import dataclasses
import math
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from conftest import TINY_PROTOCOL1
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from antmaze_hirl import PathOracle
from antmaze_hirl.cli import main
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy, RewardBasedQuery
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.experiments import run_experiment
from antmaze_hirl.experiments.tensorboard import SCALARS, DAggerTensorBoard, trial_log_dir

TINY = dataclasses.replace(TINY_PROTOCOL1, eval_episodes=1, final_eval_episodes=2)


def scalars(log_dir):
    """``tag -> [(step, value)]`` of the event file(s) in ``log_dir``."""
    events = EventAccumulator(str(log_dir))
    events.Reload()
    return {tag: [(e.step, e.value) for e in events.Scalars(tag)] for tag in events.Tags()["scalars"]}


def number(cell):
    """A CSV cell as the float TensorBoard logs (``True``/``False`` as 1/0)."""
    return {"True": 1.0, "False": 0.0}[cell] if cell in ("True", "False") else float(cell)


@pytest.fixture
def losses(monkeypatch):
    """Every loss the high-level learner's updates return, in order."""
    returned = []
    fit_dataset = HighLevelPolicy.fit_dataset

    def recording(self, *args, **kwargs):
        returned.append(fit_dataset(self, *args, **kwargs))
        return returned[-1]

    monkeypatch.setattr(HighLevelPolicy, "fit_dataset", recording)
    return returned


@pytest.mark.integration
def test_a_trial_logs_each_episode_and_changes_no_result(tmp_path, losses):
    run_experiment(["reward"], 1, TINY, tmp_path / "off", progress_bar=False, tensorboard=False)
    del losses[:]
    run_experiment(["reward"], 1, TINY, tmp_path / "on", progress_bar=False)
    for table in ("episodes.csv", "trials/reward_seed0.csv"):
        assert (tmp_path / "on" / table).read_text() == (tmp_path / "off" / table).read_text(), table
    # The logs live apart from trials/, whose CSVs mark the finished trials a resume skips.
    assert sorted(p.name for p in (tmp_path / "on" / "trials").iterdir()) == ["reward_seed0.csv", "reward_seed0.json"]
    assert not (tmp_path / "off" / "tb").exists()

    rows = list(csv.DictReader((tmp_path / "on" / "episodes.csv").open()))
    logged = scalars(trial_log_dir(tmp_path / "on", "reward", 0))
    for tag, column in SCALARS.items():
        values = [(int(number(row["episode"])), number(row[column])) for row in rows]
        expected = [(step, value) for step, value in values if not math.isnan(value)]
        assert [(step, pytest.approx(value)) for step, value in expected] == logged[tag], tag
    assert [step for step, _ in logged["eval/success"]] == [1, 2]  # every 2nd episode and the last
    # One update after each episode: its loss, as the learner returned it, at that episode's step.
    assert len(losses) == 3
    assert logged["train/loss"] == [(step, pytest.approx(loss)) for step, loss in enumerate(losses)]


def test_a_rerun_trial_replaces_its_curves(tmp_path):
    log_dir = tmp_path / "tb" / "dagger_seed0"
    with DAggerTensorBoard(log_dir) as board:
        # What an interrupted run left behind: an episode the rerun will not reach.
        board.write_episode({"episode": 7, "success": True}, SimpleNamespace(updates=0, last_loss=None))
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())
    rng = np.random.default_rng(0)
    trainer = DAggerTrainer(
        env=env,
        expert=PathOracle.for_env(env),
        learner=HighLevelPolicy.for_env(env, rng=rng),
        rng=rng,
        strategy=RewardBasedQuery(),
        episodes_per_update=2,
        gradient_steps=2,
    )
    with DAggerTensorBoard(log_dir) as board:
        records = trainer.train(4, callback=board.callback(trainer))
    logged = scalars(log_dir)
    assert logged["episode/success"] == [(r.episode, float(r.success)) for r in records]
    assert logged["episode/beta"] == [(r.episode, pytest.approx(r.beta)) for r in records]
    assert logged["episode/removed"] == [(r.episode, float(r.removed)) for r in records]
    assert [step for step, _ in logged["train/loss"]] == [1, 3]  # an update every second episode
    assert "eval/success" not in logged  # a plain trainer evaluates nothing


def test_experiment_cli_writes_tensorboard_unless_told_not_to(tmp_path, monkeypatch):
    from antmaze_hirl.experiments import runner

    told = []
    monkeypatch.setattr(runner, "run_experiment", lambda *args, **kwargs: told.append(kwargs) or {"methods": {}})
    args = ["experiment", "--methods", "dagger", "--out", str(tmp_path), "--no-progress"]
    assert main(args) == 0 and main([*args, "--no-tensorboard"]) == 0 and main([*args, "--tensorboard"]) == 0
    assert [kwargs["tensorboard"] for kwargs in told] == [True, False, True]
