"""Uncertainty-gated queries (method ``gated``): the gate, its threshold, the trainer's unasked steps, composition."""

import numpy as np
import pytest
from conftest import make_point_trainer, point_maze
from script_helpers import load_script

from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import (
    GatedQuery,
    HighLevelPolicy,
    MultiPolicyQuery,
    NoiseQuery,
    QueryStrategy,
    RewardBasedQuery,
    make_strategy,
)
from antmaze_hirl.dagger.features import EncodedBatch
from antmaze_hirl.dagger.gating import QuantileThreshold, RiskModel, disagreement
from antmaze_hirl.dagger.strategies import METHODS
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.experiments.runner import check_methods


def drive_by_hand(trainer, episodes):
    """A page's way: show the steps walked before each request, answer it later, show what ran."""
    records, walked = [], []
    for _ in range(episodes):
        run = trainer.start_episode()
        walked.extend(run.executed)
        while not run.done:
            executed = run.answer(trainer.expert.label(run.request.observation))
            walked.extend(executed)
        run.finish()
        records.append(run.record)
    return records, walked


# --- the gate on crafted ensembles ---


class CraftedMember:
    """An ensemble member that agrees with the others unless the goal lies to the agent's right."""

    def __init__(self, sign):
        self.sign = sign

    def offsets(self, batch):
        right = batch.vectors[:, 0] > 0  # goal offset x, in cells
        return np.where(right[:, None], [[0.5 * self.sign, 0.0]], [[0.3, 0.1]])


def crafted_gate(policy):
    strategy = GatedQuery(n_policies=3)
    strategy.attach(policy)
    strategy.ensemble.members = [CraftedMember(sign) for sign in (-1, 0, 1)]
    strategy.threshold.value = 0.05
    return strategy


def test_the_gate_opens_exactly_where_crafted_members_disagree():
    geometry = MazeGeometry(5, 5, 1.0)
    policy = HighLevelPolicy(geometry, pixels_per_cell=4, body_dim=2, rng=np.random.default_rng(0))
    strategy = crafted_gate(policy)
    walls = validate_maze_map("u")
    cells = [(1, 1), (1, 2), (1, 3), (2, 3), (3, 3), (3, 2)]
    agents = np.stack([geometry.cell_to_xy(cell) for cell in cells])
    goal = geometry.cell_to_xy((1, 2))  # right of (1, 1) only
    encoded = policy.encoder.encode([walls] * len(cells), list(agents), [goal] * len(cells), [np.zeros(2)] * len(cells))
    novelty = strategy.novelty(encoded)
    expected = np.array([True] + [False] * 5)
    np.testing.assert_allclose(novelty[expected], 1 / 3)  # members at -0.5, 0, 0.5: mean distance 1/3
    np.testing.assert_allclose(novelty[~expected], 0.0, atol=1e-12)
    np.testing.assert_array_equal([strategy.threshold.opens(v) for v in novelty], expected)


def test_wants_label_reads_the_ensemble_on_real_observations():
    env = point_maze()
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0))
    strategy = crafted_gate(policy)
    opened = []
    for seed in range(12):
        obs, _ = env.reset(seed=seed)
        dx = obs["state"][2] - obs["state"][0]  # goal x minus agent x, metres
        opened.append(strategy.wants_label(obs, policy.predict(obs), policy))
        if abs(dx) > 0.5:  # clearly to one side (the grid vector rounds within a cell)
            assert opened[-1] == (dx > 0)
    assert len(strategy.reference) == 12 and 0 < sum(opened) < 12  # every state joins the reference set


def test_no_ensemble_yet_means_ask_everywhere():
    batch = EncodedBatch(np.zeros((2, 2, 3, 3), np.float32), np.zeros((2, 6), np.float32))
    assert np.isinf(GatedQuery().novelty(batch)).all()


def test_disagreement_is_the_mean_distance_from_the_members_mean():
    outputs = np.array([[[0.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [-1.0, 0.0]], [[0.6, 0.8], [-0.6, -0.8]]])
    np.testing.assert_allclose(disagreement(outputs), [0.0, 1.0, 1.0])


# --- the threshold ---


@pytest.mark.parametrize("target_rate", [0.1, 0.2, 0.5])
def test_the_threshold_tracks_the_target_rate_on_a_drifting_stream(target_rate):
    # Disagreement that shrinks as a learner improves: each round is fitted on the last one's values.
    rng, threshold, rates = np.random.default_rng(0), QuantileThreshold(target_rate), []
    previous = rng.exponential(1.0, size=400)
    for round_ in range(1, 30):
        threshold.fit(previous)
        current = rng.exponential(1.0 / (1 + 0.05 * round_), size=400)
        rates.append(np.mean([threshold.opens(v) for v in current]))
        previous = current
    assert abs(np.mean(rates) - target_rate) < 0.04, rates
    assert threshold.value < np.quantile(rng.exponential(1.0, size=4000), 1 - target_rate)  # it fell with the stream


def test_the_threshold_opens_everywhere_before_its_first_fit_and_keeps_its_value_without_scores():
    threshold = QuantileThreshold(0.2)
    assert threshold.opens(0.0)
    threshold.fit(np.arange(101.0))
    assert threshold.value == pytest.approx(80.0)
    assert threshold.fit(np.array([])) == pytest.approx(80.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"target_rate": 0.0}, "target_rate must be in \\(0, 1\\), got 0.0"),
        ({"target_rate": 1.5}, "target_rate must be in \\(0, 1\\), got 1.5"),
        ({"risk_threshold": 1.0}, "risk_threshold must be in \\(0, 1\\), got 1.0"),
        ({"risk_steps": 0}, "risk_steps must be >= 1, got 0"),
        ({"reference_size": 0}, "reference size must be >= 1, got 0"),
        ({"n_policies": 1}, "n_policies must be >= 2"),
        ({"inner": GatedQuery()}, "cannot wrap 'gated'"),
        ({"inner": make_strategy("reward_per_step")}, "cannot wrap 'reward_per_step'"),
    ],
)
def test_bad_settings_are_refused_with_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message):
        GatedQuery(**kwargs)


# --- the trainer: unasked steps ---


class EveryOtherStep(QueryStrategy):
    """A gate that opens on every other step of an episode (and counts what it saw)."""

    name = "every_other"
    gates = True

    def __init__(self, first_asked=0):
        self.first_asked = first_asked
        self.calls = 0

    def wants_label(self, observation, learner_subgoal, learner):
        self.calls += 1
        return self.calls > self.first_asked and (self.calls - self.first_asked) % 2 == 1

    def on_episode_end(self, dataset, episode, success, rng):
        self.calls = 0
        return []


def test_unasked_steps_add_nothing_and_cost_nothing():
    trainer = make_point_trainer(EveryOtherStep())
    trainer.train(1)  # D empty: every step of the first episode is asked
    size = len(trainer.dataset)
    records, walked = drive_by_hand(trainer, 3)
    asked = [step for step in walked if step.asked]
    assert 0 < len(asked) < len(walked) == sum(r.attempts for r in records)
    assert sum(r.expert_cost for r in records) == len(asked) == len(trainer.dataset) - size
    assert trainer.total_expert_cost == size + len(asked)
    low, high = trainer.env.unwrapped.action_space.low, trainer.env.unwrapped.action_space.high
    for step in walked:
        if step.asked:
            np.testing.assert_allclose(step.subgoal, np.clip(step.expert_subgoal, low, high))  # the expert takes over
    stored = trainer.dataset.states[size:]
    np.testing.assert_array_equal(stored, np.stack([step.observation["state"] for step in asked]))
    assert all(r.beta == 1.0 for r in records)


class Perfect:
    """A learner that already is the oracle (so an unasked episode reaches its goal), never proposing a no-op."""

    def __init__(self, env, rng):
        self.oracle = PathOracle.for_env(env)
        self.reach = env.unwrapped.min_subgoal_distance_m * 1.05

    def predict(self, observation):
        agent = observation["state"][:2].astype(np.float64)
        offset = self.oracle.label(observation) - agent
        return agent + offset * max(1.0, self.reach / max(np.linalg.norm(offset), 1e-9))  # past the goal if near it

    def fit_dataset(self, dataset, steps):
        return 0.0


class NeverAsk(QueryStrategy):
    name = "never"
    gates = True

    def wants_label(self, observation, learner_subgoal, learner):
        return False


def test_an_episode_can_end_without_a_request_and_a_request_can_come_after_unasked_steps():
    trainer = make_point_trainer(NeverAsk(), learner=Perfect)
    first = trainer.start_episode()
    assert first.request is not None and first.executed == []  # D is empty: the gate is open
    while not first.done:
        first.answer(trainer.expert.label(first.request.observation))
    first.finish()
    run = trainer.start_episode()
    assert run.done and run.request is None and run.record.expert_cost == 0
    assert len(run.executed) == run.record.attempts > 0 and not any(step.asked for step in run.executed)
    run.finish()
    late = make_point_trainer(EveryOtherStep(first_asked=2), learner=Perfect, env=point_maze(min_goal_cells=3))
    late.train(1)
    run = late.start_episode()
    if run.done:  # reached within two steps: nothing to check on this maze
        pytest.skip("the goal was reached before the third step")
    assert len(run.executed) == 2 and run.request.label_index == 0
    np.testing.assert_array_equal(run.request.observation["state"], late.env.unwrapped._get_obs()["state"])


class CornerSeeker:
    """A learner pointing past the top-right border: clipped, its subgoal is a no-op in that corner."""

    def __init__(self, env, rng):
        self.inner = HighLevelPolicy.for_env(env, rng=rng)

    def predict(self, observation):
        return np.array([50.0, 50.0])

    def fit_dataset(self, dataset, steps):
        return 0.0


def test_a_no_op_proposal_opens_the_gate():
    trainer = make_point_trainer(NeverAsk(), learner=CornerSeeker, env=point_maze(max_steps=200))
    records, walked = drive_by_hand(trainer, 4)
    # Unasked, the agent would park in the corner and repeat the no-op until the step budget ran out.
    assert max(r.attempts for r in records) < 60 and sum(r.expert_cost for r in records[1:]) > 0
    corner = trainer.env.unwrapped.action_space.high
    for step in walked[records[0].attempts :]:  # after the first episode (D empty: all asked)
        assert step.asked == (np.linalg.norm(step.observation["state"][:2] - corner) < 0.5)


# --- ask/tell and run_episode ---


@pytest.mark.parametrize(
    "make",
    [
        lambda: GatedQuery(n_policies=2),
        lambda: GatedQuery(inner=RewardBasedQuery(), n_policies=2, risk=True, label_failures=True, risk_steps=5),
    ],
)
def test_ask_tell_gives_the_same_records_as_run_episode(make):
    env_settings = {"max_steps": 60}
    synchronous = make_point_trainer(make(), env=point_maze(**env_settings))
    by_hand = make_point_trainer(make(), env=point_maze(**env_settings))
    expected = [r.to_dict() for r in synchronous.train(4)]
    records, _ = drive_by_hand(by_hand, 4)
    assert [r.to_dict() for r in records] == expected
    np.testing.assert_array_equal(by_hand.dataset.subgoals(), synchronous.dataset.subgoals())


def test_labels_after_a_failure_execute_nothing_and_count():
    trainer = make_point_trainer(GatedQuery(n_policies=2, label_failures=True), env=point_maze(max_steps=40))
    trainer.train(2)
    seen = 0
    for _ in range(6):
        run = trainer.start_episode()
        walked = list(run.executed)
        after = 0
        while not run.done:
            request = run.request
            executed = run.answer(trainer.expert.label(request.observation))
            if not request.executes:
                assert executed == []  # nothing ran
                after += 1
            walked.extend(executed)
        run.finish()
        unasked = sum(not step.asked for step in walked)
        assert after == (0 if run.record.success else unasked)
        assert run.record.expert_cost == sum(step.asked for step in walked) + after
        seen += after
    assert seen > 0  # some episode failed with unasked steps


# --- composition ---


def test_gated_composes_with_reward_pruning_of_asked_labels():
    trainer = make_point_trainer(make_strategy("gated+reward"), env=point_maze(max_steps=40))
    records, walked = drive_by_hand(trainer, 8)
    failed = [r for r in records if not r.success]
    labelled = [r for r in failed if r.expert_cost]
    assert labelled and all(r.removed >= 1 for r in labelled)  # the last asked label goes (t_d = 0)
    assert all(r.removed == 0 for r in records if r.success)
    assert len(trainer.dataset) == sum(r.expert_cost - r.removed for r in records)
    assert sum(r.expert_cost for r in records) == sum(step.asked for step in walked)


def test_method_names_compose_and_bad_ones_are_refused():
    assert isinstance(make_strategy("gated+reward").inner, RewardBasedQuery)
    assert isinstance(make_strategy("gated+noise").inner, NoiseQuery)
    shared = make_strategy("gated+multi_policy")
    assert isinstance(shared.inner, MultiPolicyQuery) and shared.ensemble is shared.inner  # one ensemble
    assert [make_strategy(name).method for name in ("gated", "gated+reward")] == ["gated", "gated+reward"]
    check_methods(["dagger", "gated", "gated+reward"])
    for bad in ("gated+gated", "gated+reward_per_step", "gated+dagger", "reward+gated", "gated+"):
        with pytest.raises(ValueError, match=f"unknown method '{bad.replace('+', '[+]')}'"):
            make_strategy(bad)
    assert "gated+noise" in METHODS


@pytest.mark.integration  # a lab check: the problem and the figure come from scripts/learning_margins.py
def test_risk_model_learns_which_subgoals_fail():
    learning_margins = load_script("scripts/learning_margins.py")  # each check's figure, one per seed
    features, _ = learning_margins.risk_problem(0)
    assert np.all(RiskModel(rng=np.random.default_rng(1)).predict(features) == 0)  # no evidence before the first fit
    # Failed where the first of 6 normal features is above 0.5; 300 steps. Over seeds 0-9 at 96ae2e5 the
    # accuracy was 0.965-0.988 (median 0.974, sd 0.008; `python scripts/learning_margins.py risk_model
    # --seeds 0-9`): the bound 0.9 sits 0.065 under the lowest seed, ~9 sd under the mean.
    assert learning_margins.risk_model_accuracy(0) > 0.9


# --- end to end ---


@pytest.mark.integration
def test_a_short_point_run_spends_fewer_labels_than_attempts_and_learns():
    # The heading head: the point's default planner already walks these small mazes untrained. Over seeds
    # 0-9 at 96ae2e5, 8 episodes took 9-30 labels for 42-76 attempts, and success on the 15 mazes rose by
    # 0.13-0.80 (median 0.50, mean 0.49, sd 0.17), so one seed is no test; the mean of 3 consecutive seeds
    # rose by 0.47-0.62 (sd ~0.1), and the bound 0.1 on the mean of seeds 0-2 sits 0.37 under the lowest:
    # `python scripts/learning_margins.py gated_gain --seeds 0-9 --window 3`.
    learning_margins = load_script("scripts/learning_margins.py")
    gains = []
    for seed in range(3):
        run = learning_margins.gated_run(seed)
        assert run["labels"] < run["attempts"], (seed, run)
        gains.append(run["gain"])
    assert np.mean(gains) > 0.1, gains
