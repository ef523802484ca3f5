"""Issue 32: the start scores of Alg. 2 and 3 carry a continuous signal, and starts keep min_goal_cells."""

import gymnasium as gym
import numpy as np
import pytest
from script_helpers import load_script

from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy
from antmaze_hirl.dagger.features import SYMMETRIES
from antmaze_hirl.dagger.network import NEXT_CELL_MOVES
from antmaze_hirl.dagger.strategies import (
    MultiPolicyQuery,
    NoiseQuery,
    StartQuery,
    argmax_ties_random,
    class_probabilities,
)
from antmaze_hirl.dagger.symmetric_views import class_directions, class_permutations, learner_planar_feature_dim
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.layouts import bfs_distances, generate_layout

GENERIC = {"head": "next_cell", "planning_iterations": 0, "block_walls": False}


def point_env(**kwargs):
    return gym.make("antmaze_hirl/PointMaze-v0", maze_size=4, low_level=PointGoToController(), **kwargs)


def start_query(policy, seed):
    rng = np.random.default_rng(seed)
    layout = generate_layout(rng, n_rows=4, n_cols=4)
    geometry = policy.geometry
    cells = [tuple(cell) for cell in np.argwhere(~layout.walls) if tuple(cell) != layout.goal_cell]
    candidates = np.stack([geometry.cell_to_xy(cell) for cell in cells])
    return StartQuery(layout.walls, geometry.cell_to_xy(layout.goal_cell), candidates, np.zeros(2), policy)


HEADING = {"head": "heading", "planning_iterations": 0, "block_walls": False}


@pytest.mark.parametrize("settings", [GENERIC, HEADING], ids=["next_cell", "heading"])
def test_the_noise_score_of_the_class_distribution_is_nonzero_where_the_offsets_is_zero(settings):
    env = point_env()
    zero_offsets = 0
    for seed in range(3):
        policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(seed), **settings)
        query = start_query(policy, seed)
        probabilities = NoiseQuery().scores(query, np.random.default_rng(seed))
        offsets = NoiseQuery(signal="offsets", symmetries=False).scores(query, np.random.default_rng(seed))
        assert probabilities.min() > 1e-14, probabilities  # the body noise moves every distribution
        assert len(np.unique(probabilities)) == len(probabilities)  # no ties for the argmax to break by position
        zero_offsets += int((offsets < 1e-20).sum())
        distribution = class_probabilities(policy, query.encode(query.candidates, np.zeros((len(query.candidates), 2))))
        np.testing.assert_allclose(distribution.sum(axis=1), 1.0)
    if settings["head"] == "next_cell":
        assert zero_offsets > 0  # the protocol-1 score: an argmax class does not move under small noise
    env.close()


def test_ties_are_broken_at_random_not_by_position():
    picks = {argmax_ties_random(np.zeros(6), np.random.default_rng(seed)) for seed in range(40)}
    assert picks == set(range(6))
    assert argmax_ties_random(np.array([0.0, 3.0, 1.0, 3.0 - 1e-15]), np.random.default_rng(0)) in (1, 3)
    assert argmax_ties_random(np.array([0.0, 3.0, 1.0, 2.0]), np.random.default_rng(0)) == 1


def test_unknown_signal_and_a_learner_without_a_distribution_are_clear_errors():
    with pytest.raises(ValueError, match="signal must be one of \\['probabilities', 'offsets'\\], got 'argmax'"):
        NoiseQuery(signal="argmax")
    with pytest.raises(ValueError, match="signal must be one of"):
        MultiPolicyQuery(signal="x")
    with pytest.raises(ValueError, match="object has no class distribution"):
        class_probabilities(object(), None)


class Recording:
    """Wraps a strategy's choose_start and keeps every query's candidates and the start chosen."""

    def __init__(self, strategy):
        self.strategy, self.seen = strategy, []
        original = strategy.choose_start

        def choose_start(query, rng):
            start = original(query, rng)
            self.seen.append((query, start))
            return start

        strategy.choose_start = choose_start


@pytest.mark.parametrize("make", [NoiseQuery, lambda: MultiPolicyQuery(n_policies=2)], ids=["noise", "multi_policy"])
def test_chosen_starts_respect_min_goal_cells(make):
    env = point_env(min_goal_cells=3)
    rng = np.random.default_rng(0)
    strategy = make()
    recording = Recording(strategy)
    policy = HighLevelPolicy.for_env(env, rng=rng, **GENERIC)
    trainer = DAggerTrainer(
        env=env, expert=PathOracle.for_env(env), learner=policy, rng=rng, strategy=strategy, gradient_steps=2
    )
    trainer.train(4)
    geometry = env.unwrapped.geometry
    assert recording.seen
    for query, start in recording.seen:
        steps = bfs_distances(query.walls, geometry.xy_to_cell(query.goal_xy))
        assert all(steps[geometry.xy_to_cell(xy)] >= 3 for xy in query.candidates)
        assert start is None or steps[geometry.xy_to_cell(start)] >= 3
    env.close()


class FrameLearner:
    """A next-cell learner whose class distribution is a function of the encoded goal offset alone.

    ``equivariant``: ``p(c) ~ exp(3 move_c . goal)`` answers every symmetric image of a state alike once
    read back in the state's frame; otherwise ``p(c) ~ exp(3 move_c.x goal.x)`` favours the x axis.
    """

    head = "next_cell"
    planar_feature_dim = 6

    def __init__(self, encoder, equivariant):
        self.encoder, self.geometry, self.equivariant = encoder, encoder.geometry, equivariant

    def class_probabilities(self, batch):
        goal = batch.vectors[:, 0:2].astype(np.float64)
        moves = np.asarray(NEXT_CELL_MOVES, dtype=np.float64)
        logits = 3 * (goal @ moves.T if self.equivariant else goal[:, :1] * moves[None, :, 0])
        weights = np.exp(logits - logits.max(axis=1, keepdims=True))
        return weights / weights.sum(axis=1, keepdims=True)

    def offsets(self, batch):
        goal = batch.vectors[:, 0:2].astype(np.float64)
        return goal if self.equivariant else np.abs(goal)


@pytest.mark.parametrize("signal", ["probabilities", "offsets"])
def test_symmetric_views_are_read_back_in_the_states_frame(signal):
    # A learner that answers a state's 8 images alike scores 0 however its answers vary across states;
    # one that does not scores above 0: the views are turned back before their spread is taken.
    env = point_env()
    encoder = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **GENERIC).encoder
    query = start_query(FrameLearner(encoder, equivariant=True), 0)
    same = NoiseQuery(signal=signal).scores(query, np.random.default_rng(0))
    np.testing.assert_allclose(same, 0.0, atol=1e-9)
    query = start_query(FrameLearner(encoder, equivariant=False), 0)
    differ = NoiseQuery(signal=signal).scores(query, np.random.default_rng(0))
    assert differ.min() > 1e-3, differ
    assert np.all(NoiseQuery(signal=signal, symmetries=False).scores(query, np.random.default_rng(0)) < 1e-9)
    env.close()


def test_heading_bins_and_next_cells_are_permuted_as_the_symmetries_turn_them():
    env = point_env()
    heading = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**HEADING, "n_directions": 16})
    permutations = class_permutations(class_directions(heading))
    for (k, flip), permutation in zip(SYMMETRIES, permutations, strict=True):
        assert sorted(permutation) == list(range(16))
        if not flip:
            np.testing.assert_array_equal(permutation, (np.arange(16) + 4 * k) % 16)  # a quarter turn: 4 bins on
    cells = class_permutations(class_directions(HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **GENERIC)))
    east, north = NEXT_CELL_MOVES.index((1, 0)), NEXT_CELL_MOVES.index((0, 1))
    assert cells[SYMMETRIES.index((1, False))][east] == north  # counter-clockwise
    env.close()


def test_bad_symmetric_settings_are_clear_errors():
    with pytest.raises(ValueError, match="measure must be one of \\['js', 'variance'\\], got 'kl'"):
        NoiseQuery(measure="kl")
    with pytest.raises(ValueError, match="measure 'js' compares class distributions: use signal='probabilities'"):
        NoiseQuery(signal="offsets", measure="js")
    with pytest.raises(ValueError, match="object states no planar_feature_dim"):
        learner_planar_feature_dim(object())
    with pytest.raises(ValueError, match="classes of unknown directions"):
        class_directions(object())


@pytest.mark.integration  # a lab check: the fitted AUCs come from scripts/alg2_signal.py
def test_the_noise_score_ranks_states_the_learner_has_not_seen_above_those_it_was_trained_on():
    alg2_signal = load_script("scripts/alg2_signal.py")
    # alg2_signal.fitted_aucs: a learner fitted to the oracle on two mazes, and an untrained one, both
    # scored at those states and at the oracle's states on four other mazes. Over seeds 0-9
    # (results/alg2_signal/alg2_signal_fitted.json) the fitted AUC is 0.60-0.98, the mean of any two
    # consecutive seeds >= 0.62; fitted - untrained is 0.20-0.41 on every seed (two-seed means >= 0.23).
    # The bars sit well below both, so they hold where another CPU's rounding trains other weights.
    # The paired difference is the robust figure: the state sets differ by the luck of the mazes, which
    # the untrained learner's AUC (0.36-0.71) shows.
    env = point_env()
    fitted, untrained = zip(*(alg2_signal.fitted_aucs(env, seed) for seed in range(2)), strict=True)
    assert np.mean(fitted) > 0.55, (fitted, untrained)
    assert np.mean(fitted) - np.mean(untrained) > 0.1, (fitted, untrained)
    env.close()
