"""The trainer, the learner and the strategy draw from independent streams: one's draws never shift another's."""

import numpy as np
import pytest
import torch as th
from conftest import make_point_trainer, point_maze

from antmaze_hirl.dagger import DAggerQuery, NoiseQuery, RewardBasedQuery
from antmaze_hirl.dagger.streams import spawn_generators, trainer_streams, trial_streams
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.old_folders import SETTINGS_BEFORE_PROTOCOL_2
from antmaze_hirl.experiments.runner import make_trainer
from antmaze_hirl.experts.oracle import PathOracle


class GreedyDAgger(DAggerQuery):
    """Plain DAgger that draws many numbers from the strategy's stream at every hook and uses none of them."""

    name = "greedy"

    def on_update(self, dataset, gradient_steps, rng):
        rng.random(997)

    def on_episode_end(self, dataset, episode, success, rng):
        rng.random(13)
        return super().on_episode_end(dataset, episode, success, rng)


def tasks_and_weights(strategy, episodes=4, seed=0):
    """Each episode's (walls, goal) and the learner's weights at the end."""
    trainer = make_point_trainer(strategy, seed)
    tasks = []
    for _ in range(episodes):
        trainer.run_episode()
        unwrapped = trainer.env.unwrapped
        tasks.append((unwrapped.layout.walls.copy(), unwrapped.goal_xy.copy()))
    weights = [p.detach().clone() for p in trainer.learner.network.parameters()]
    return tasks, weights


def same_tasks(first, second):
    return all(np.array_equal(a[0], b[0]) and np.allclose(a[1], b[1]) for a, b in zip(first, second, strict=True))


def test_a_strategy_drawing_extra_numbers_changes_neither_the_tasks_nor_the_learner():
    plain_tasks, plain_weights = tasks_and_weights(DAggerQuery())
    greedy_tasks, greedy_weights = tasks_and_weights(GreedyDAgger())
    assert same_tasks(plain_tasks, greedy_tasks)
    # The same labels on the same tasks, and minibatches from the learner's own stream: the same weights.
    assert all(th.equal(a, b) for a, b in zip(plain_weights, greedy_weights, strict=True))


def test_the_streams_discriminate_seeds():
    # The check above would pass if no stream depended on the seed: another seed gives other tasks.
    first, _ = tasks_and_weights(DAggerQuery(), seed=0)
    other, _ = tasks_and_weights(DAggerQuery(), seed=1)
    assert not same_tasks(first, other)


@pytest.mark.parametrize("method", [NoiseQuery, RewardBasedQuery])
def test_two_methods_on_one_seed_train_on_the_same_mazes_and_goals(method):
    # noise chooses its own starts and reward prunes with draws of its own; the mazes and goals stay DAgger's.
    dagger_tasks, _ = tasks_and_weights(DAggerQuery())
    method_tasks, _ = tasks_and_weights(method())
    assert same_tasks(dagger_tasks, method_tasks)


def test_make_trainer_gives_every_method_the_same_untrained_learner_and_first_task():
    config = ExperimentConfig(body="point", maze_size=3, **SETTINGS_BEFORE_PROTOCOL_2)
    first = {}
    for method in ("dagger", "multi_policy"):
        env = point_maze()
        trainer = make_trainer(method, 5, config, env, PathOracle.for_env(env))
        weights = [p.detach().clone() for p in trainer.learner.network.parameters()]
        run = trainer.start_episode()
        first[method] = (weights, env.unwrapped.layout.walls.copy(), env.unwrapped.goal_xy.copy())
        assert run.request is not None
    (w1, walls1, goal1), (w2, walls2, goal2) = first["dagger"], first["multi_policy"]
    assert all(th.equal(a, b) for a, b in zip(w1, w2, strict=True))
    assert np.array_equal(walls1, walls2) and np.allclose(goal1, goal2)


def test_spawned_streams_ignore_the_parents_own_draws():
    rng = np.random.default_rng(3)
    before = [child.random(4) for child in trainer_streams(np.random.default_rng(3))]
    rng.random(100)  # the learner, sharing this rng, draws
    after = [child.random(4) for child in trainer_streams(rng)]
    assert all(np.array_equal(a, b) for a, b in zip(before, after, strict=True))
    assert not np.array_equal(before[0], before[1])  # and the children differ from each other


def test_trial_streams_are_seeded_and_distinct():
    first, again, other = trial_streams(7), trial_streams(7), trial_streams(8)
    assert first.learner.random() == again.learner.random()
    assert first.trainer.random() == again.trainer.random()
    assert trial_streams(7).learner.random() != other.learner.random()
    assert trial_streams(7).learner.random() != trial_streams(7).trainer.random()


def test_spawn_generators_rejects_a_count_below_one():
    with pytest.raises(ValueError, match="count must be >= 1, got 0"):
        spawn_generators(np.random.default_rng(0), 0)
