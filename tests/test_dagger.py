import gymnasium as gym
import numpy as np
import pytest
from conftest import make_point_trainer
from script_helpers import load_script

from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import (
    DAggerTrainer,
    Demonstration,
    DemonstrationDataset,
    HighLevelPolicy,
    InverseDecayBetaSchedule,
    LinearBetaSchedule,
    MultiPolicyQuery,
    NoiseQuery,
    RewardBasedQuery,
    evaluate_high_level,
)
from antmaze_hirl.dagger.agent import HierarchicalAgent
from antmaze_hirl.dagger.features import (
    SYMMETRIES,
    EncodedBatch,
    ObservationEncoder,
    augment,
    transform_grids,
    transform_planar,
)
from antmaze_hirl.dagger.strategies import StartQuery
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.envs.state_layout import STATE_LAYOUT

GEOMETRY = MazeGeometry(5, 5, 1.0)


def demo(episode, step):
    return Demonstration(np.zeros((3, 8, 8), np.uint8), np.zeros(6, np.float32), np.zeros(2), episode, step)


def failed_episode_dataset(length):
    dataset = DemonstrationDataset()
    for step in range(length):
        dataset.add(demo(episode=0, step=step))
    return dataset


def test_reward_based_removal_frequency_matches_exp_minus_t_d():
    strategy, rng, length, trials = RewardBasedQuery(), np.random.default_rng(0), 5, 4000
    removed_counts = np.zeros(length)
    for _ in range(trials):
        dataset = failed_episode_dataset(length)
        for index in strategy.on_episode_end(dataset, 0, success=False, rng=rng):
            removed_counts[index] += 1
    expected = np.exp(-np.arange(length)[::-1])  # the last sample has t_d = 0
    frequency = removed_counts / trials
    tolerance = 4 * np.sqrt(expected * (1 - expected) / trials) + 1e-9
    assert np.all(np.abs(frequency - expected) <= tolerance), (frequency, expected)


def test_reward_based_keeps_successful_episodes_and_other_episodes():
    strategy, rng = RewardBasedQuery(), np.random.default_rng(0)
    dataset = failed_episode_dataset(4)
    dataset.add(demo(episode=1, step=0))
    assert strategy.on_episode_end(dataset, 0, success=True, rng=rng) == []
    assert len(dataset) == 5
    strategy.on_episode_end(dataset, 1, success=False, rng=rng)  # t_d = 0: always removed
    assert len(dataset) == 4 and all(d.episode == 0 for d in dataset.demonstrations)


class CraftedPolicy:
    """Outputs vary with the body observation only when the goal is exactly 2 cells to the agent's right."""

    def __init__(self):
        self.encoder = ObservationEncoder(GEOMETRY, pixels_per_cell=4)

    def offsets(self, batch):
        sensitive = np.isclose(batch.vectors[:, 0], 2.0) & np.isclose(batch.vectors[:, 1], 0.0)
        return np.where(sensitive[:, None], batch.vectors[:, 4:6], 0.0)


def start_query(policy):
    walls = validate_maze_map("u")
    candidates = np.stack([GEOMETRY.cell_to_xy(cell) for cell in [(1, 1), (1, 2), (1, 3), (2, 3)]])
    goal = GEOMETRY.cell_to_xy((1, 3))  # two cells right of (1, 1)
    return StartQuery(walls, goal, candidates, np.zeros(2), policy)


def test_noise_based_picks_the_candidate_where_the_policy_varies():
    query = start_query(CraftedPolicy())
    scores = NoiseQuery(n_noises=8, signal="offsets", symmetries=False).scores(query, np.random.default_rng(0))
    assert scores[0] > 0 and np.all(scores[1:] == 0)
    chosen = NoiseQuery(signal="offsets", symmetries=False).choose_start(query, np.random.default_rng(1))
    np.testing.assert_array_equal(chosen, query.candidates[0])


class ConstantMember:
    """An ensemble member that agrees with the others everywhere except at one candidate."""

    def __init__(self, disagreement):
        self.disagreement = disagreement

    def offsets(self, batch):
        out = np.zeros((len(batch), 2))
        out[2] = self.disagreement  # third candidate
        return out


def test_multi_policy_picks_where_members_disagree():
    query = start_query(CraftedPolicy())
    strategy = MultiPolicyQuery(n_policies=3, signal="offsets")
    assert strategy.choose_start(query, np.random.default_rng(0)) is None  # no members before the first update
    strategy.members = [ConstantMember(value) for value in (-0.5, 0.0, 0.5)]
    np.testing.assert_array_equal(strategy.choose_start(query, np.random.default_rng(0)), query.candidates[2])


@pytest.mark.parametrize(("member_steps", "expected"), [(None, 4), (7, 7)])
def test_multi_policy_members_share_the_learners_gradient_budget(member_steps, expected):
    trainer = make_point_trainer(strategy=MultiPolicyQuery(n_policies=3, member_steps=member_steps), gradient_steps=10)
    trainer.train(2)
    updates = 2
    assert [member.gradient_steps for member in trainer.strategy.members] == [expected * updates] * 3
    with pytest.raises(ValueError, match="member_steps must be >= 1, got 0"):
        MultiPolicyQuery(member_steps=0)


def test_beta_schedules_are_exact():
    schedule = InverseDecayBetaSchedule(decay=2.0)
    assert [schedule(k) for k in range(4)] == [1.0, 0.5, 0.25, 0.125]
    assert InverseDecayBetaSchedule(decay=3.0, beta0=0.9)(2) == pytest.approx(0.9 / 9, rel=1e-15)
    # reward_per_step updates after every step: 2.0 ** 1024 overflows a float, beta must reach 0 instead.
    assert schedule(1023) == 2.0**-1023 and schedule(1100) == 0.0 and schedule(10**6) == 0.0
    assert [LinearBetaSchedule(4)(k) for k in (0, 1, 4, 9)] == [1.0, 0.75, 0.0, 0.0]
    with pytest.raises(ValueError, match="decay d must be >= 1"):
        InverseDecayBetaSchedule(decay=0.5)


def test_augmentation_keeps_grid_vector_and_label_consistent():
    encoder = ObservationEncoder(GEOMETRY, pixels_per_cell=4)
    walls = np.ones((5, 5), bool)
    walls[1:-1, 1:-1] = False
    agent, goal = GEOMETRY.cell_to_xy((2, 2)), GEOMETRY.cell_to_xy((1, 3))  # goal up-right of the agent
    batch = encoder.encode([walls] * 64, [agent] * 64, [goal] * 64, [np.zeros(2)] * 64)
    labels = np.tile((goal - agent), (64, 1)).astype(np.float32)
    augmented, new_labels = augment(batch, labels, np.random.default_rng(0))
    centre = encoder.radius - 1
    for grid, vector, label in zip(augmented.grids, augmented.vectors, new_labels, strict=True):
        (row,), (col,) = np.nonzero(grid[1])
        # grid rows grow downwards (-y), columns rightwards (+x)
        np.testing.assert_allclose(vector[:2], [col - centre, centre - row], atol=1e-6)
        np.testing.assert_allclose(label, vector[:2], atol=1e-6)
    assert len({tuple(v[:2]) for v in augmented.vectors}) == 4  # the four diagonal directions all appear


def augment_one_symmetry_at_a_time(batch, labels, rng, planar_feature_dim):
    """augment as it was written before its one gather: a masked transform per symmetry of the square."""
    grids, vectors, labels = batch.grids.copy(), batch.vectors.copy(), np.array(labels, dtype=np.float32)
    choices = rng.integers(len(SYMMETRIES), size=len(batch))
    for index, (k, flip) in enumerate(SYMMETRIES):
        members = choices == index
        if not members.any() or (k == 0 and not flip):
            continue
        grids[members] = transform_grids(grids[members], k, flip)
        vectors[members, :planar_feature_dim] = transform_planar(vectors[members, :planar_feature_dim], k, flip)
        labels[members] = transform_planar(labels[members], k, flip)
    return EncodedBatch(grids, vectors), labels


@pytest.mark.parametrize(("rows", "planar_feature_dim"), [(1, 4), (64, 4), (37, 6)])
def test_augment_gives_the_per_symmetry_transforms_bit_for_bit(rows, planar_feature_dim):
    # The learner's training batches depend on it: the same random draws must give the same batch to the bit.
    rng = np.random.default_rng(rows)
    batch = EncodedBatch(
        rng.integers(0, 2, size=(rows, 2, 9, 9)).astype(np.float32)
        * rng.normal(size=(rows, 2, 9, 9)).astype(np.float32),
        rng.normal(size=(rows, 31)).astype(np.float32),
    )
    labels = rng.normal(size=(rows, 2)).astype(np.float32)
    labels[0] = 0.0  # signed zeros must come out as the negations make them
    mine, my_labels = augment(batch, labels, np.random.default_rng(7), planar_feature_dim=planar_feature_dim)
    theirs, their_labels = augment_one_symmetry_at_a_time(batch, labels, np.random.default_rng(7), planar_feature_dim)
    for new, old in ((mine.grids, theirs.grids), (mine.vectors, theirs.vectors), (my_labels, their_labels)):
        assert new.dtype == old.dtype and new.tobytes() == old.tobytes()


def test_blend_executes_the_beta_mix_and_counts_labels():
    trainer = make_point_trainer(beta_schedule=InverseDecayBetaSchedule(decay=1.0, beta0=0.25), gradient_steps=1)
    env = trainer.env
    executed = []
    step = env.step

    def recording_step(action):
        executed.append(np.array(action))
        return step(action)

    env.step = recording_step
    labels = []
    expert_label = trainer.expert.label

    def recording_label(obs):
        labels.append((expert_label(obs), trainer.learner.predict(obs), STATE_LAYOUT.agent_xy(obs["state"])))
        return labels[-1][0]

    trainer.expert.label = recording_label
    record = trainer.run_episode()
    assert record.expert_cost == len(executed) == len(labels) == record.attempts
    for action, (expert, learner, agent) in zip(executed, labels, strict=True):
        mix = np.clip(0.25 * expert + 0.75 * learner, env.action_space.low, env.action_space.high)
        no_op = np.linalg.norm(mix - agent) < env.unwrapped.min_subgoal_distance_m
        np.testing.assert_allclose(action, expert if no_op else mix)


class CornerSeeker:
    """A learner that always points past the maze's top-right border: clipped, its subgoal is a no-op there."""

    def __init__(self, encoder):
        self.encoder = encoder

    def predict(self, observation):
        return np.array([50.0, 50.0])

    def fit_dataset(self, dataset, steps):
        return 0.0


def test_a_mix_the_agent_already_reaches_is_replaced_by_the_experts_subgoal():
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, low_level=PointGoToController())
    rng = np.random.default_rng(0)
    policy = HighLevelPolicy.for_env(env, rng=rng)
    trainer = DAggerTrainer(
        env=env,
        expert=PathOracle.for_env(env),
        learner=CornerSeeker(policy.encoder),
        rng=rng,
        beta_schedule=InverseDecayBetaSchedule(decay=1.0, beta0=0.0),
        gradient_steps=0,
    )
    records = [trainer.run_episode() for _ in range(3)]
    # Without the fallback the agent parks in the top-right corner and pays a label per low-level step.
    assert max(record.attempts for record in records) < 60


def test_switch_mixing_and_per_step_updates_run():
    trainer = make_point_trainer(mixing="switch", per_step_gradient_steps=2, gradient_steps=5)
    record = trainer.run_episode()
    assert trainer.learner.gradient_steps == 2 * record.expert_cost + 5
    assert trainer.updates == 1 and trainer.beta == 0.5


@pytest.mark.integration
def test_dagger_moves_the_learner_towards_the_experts_labels():
    # On mazes held out by seed (not by layout: the 3x3 family has few grids), the learner's subgoals get nearer
    # the oracle's: the distance after 8 episodes over the untrained one. Over seeds 0-9 at 96ae2e5 that ratio
    # spread from 0.15 to 0.61 (median 0.27, mean 0.34, sd 0.17), so one seed is no test; the mean of 5
    # consecutive seeds spread from 0.29 to 0.39, and the bound 0.7 on the mean of seeds 0-4 sits 0.3 above it:
    # `python scripts/learning_margins.py dagger_ratio --seeds 0-9 --window 5`.
    learning_margins = load_script("scripts/learning_margins.py")  # each check's figure, one per seed
    ratios = [learning_margins.dagger_distance_ratio(seed) for seed in range(5)]
    assert np.mean(ratios) < 0.7, ratios


@pytest.mark.slow
def test_dagger_learns_small_mazes_end_to_end():
    # The heading head without planning, 20 episodes: the success gain on 30 held-out 3x3 mazes. Seed 0 alone is
    # a test here: over seeds 0-7 at 4e2220a the gain was 0.80-0.97 (median 0.88, sd 0.06), so the bound 0.4 sits
    # 0.4 under the lowest seed: `python scripts/learning_margins.py dagger_end_to_end --seeds 0-7`, whose
    # function this calls. Not the point's default planning learner: it solves these mazes untrained (30 of 30),
    # and training can lower it (25 of 30 after 20 episodes on seed 0 since the random streams of 0.2.0), the
    # protocol's "strong prior" finding, reported by its ablation, not a property to assert here.
    gain = load_script("scripts/learning_margins.py").dagger_end_to_end_gain(0)
    assert gain >= 0.4, gain


@pytest.mark.parametrize(
    ("head", "planning_iterations"),
    [("heading", 0), pytest.param("heading", 4, marks=pytest.mark.integration), ("next_cell", 0)],  # planning: 5 s
)
def test_policy_save_load_round_trip_and_bad_files(tmp_path, head, planning_iterations):
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())
    rng = np.random.default_rng(0)
    policy = HighLevelPolicy.for_env(
        env, rng=rng, head=head, planning_iterations=planning_iterations, block_walls=False
    )
    trainer = DAggerTrainer(env=env, expert=PathOracle.for_env(env), learner=policy, rng=rng, gradient_steps=10)
    trainer.run_episode()
    path = trainer.learner.save(tmp_path / "high.zip")
    loaded = HighLevelPolicy.load(path)
    obs, _ = env.reset(seed=3)
    np.testing.assert_array_equal(loaded.predict(obs), trainer.learner.predict(obs))
    (tmp_path / "bad.zip").write_text("junk")
    with pytest.raises(ValueError, match="is not a high-level policy file"):
        HighLevelPolicy.load(tmp_path / "bad.zip")
    with pytest.raises(FileNotFoundError):
        HighLevelPolicy.load(tmp_path / "missing.zip")
    agent = HierarchicalAgent(loaded, PointGoToController())
    np.testing.assert_array_equal(agent.predict(obs)[0], loaded.predict(obs))
    # SB3-style (subgoal, state) predictions evaluate like plain ones
    assert evaluate_high_level(agent, env, episodes=2) == evaluate_high_level(loaded, env, episodes=2)


def test_trainer_is_seeded():
    first = [r.to_dict() for r in make_point_trainer(seed=4, gradient_steps=5).train(2)]
    second = [r.to_dict() for r in make_point_trainer(seed=4, gradient_steps=5).train(2)]
    assert first == second


@pytest.mark.parametrize("strategy", [NoiseQuery(), MultiPolicyQuery(n_policies=2)])
def test_start_selecting_strategies_start_episodes_where_they_choose(strategy):
    trainer = make_point_trainer(strategy=strategy, gradient_steps=5)
    env = trainer.env
    trainer.train(1)  # the first episode starts in a corner; afterwards the strategy picks
    chosen, starts = [], []
    choose, reset = strategy.choose_start, env.reset
    strategy.choose_start = lambda query, rng: chosen.append(choose(query, rng)) or chosen[-1]

    def recording_reset(**kwargs):
        result = reset(**kwargs)
        starts.append(env.unwrapped.agent_xy)
        return result

    env.reset = recording_reset
    trainer.train(2)
    assert len(chosen) == len(starts) == 2
    for choice, start in zip(chosen, starts, strict=True):
        assert choice is not None
        np.testing.assert_allclose(start, choice)  # the episode started exactly at the chosen candidate


def test_start_selecting_strategies_need_the_heading_policy():
    class OtherLearner:
        encoder = None

    env = gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController())
    with pytest.raises(ValueError, match="strategy 'noise' reads a HighLevelPolicy's outputs; got OtherLearner"):
        DAggerTrainer(
            env=env,
            expert=PathOracle.for_env(env),
            learner=OtherLearner(),
            rng=np.random.default_rng(0),
            strategy=NoiseQuery(),
        )
    with pytest.raises(TypeError, match="policy"):  # the keyword is learner= since 0.2.0
        DAggerTrainer(env=env, expert=PathOracle.for_env(env), policy=OtherLearner(), rng=np.random.default_rng(0))


def test_point_velocity_is_augmented_with_the_maze():
    encoder = ObservationEncoder(GEOMETRY, pixels_per_cell=4)
    walls = validate_maze_map("u")
    agent, goal = GEOMETRY.cell_to_xy((1, 1)) + 0.1, GEOMETRY.cell_to_xy((1, 3))
    velocity = np.array([0.3, -0.2])
    batch = encoder.encode([walls] * 32, [agent] * 32, [goal] * 32, [velocity] * 32)
    augmented, _ = augment(batch, np.zeros((32, 2), np.float32), np.random.default_rng(1), planar_feature_dim=6)
    original = batch.vectors[0]
    for vector in augmented.vectors:
        # a symmetry preserves the angle between the goal offset and the velocity, and both lengths
        np.testing.assert_allclose(np.dot(vector[:2], vector[4:6]), np.dot(original[:2], original[4:6]), atol=1e-6)
        np.testing.assert_allclose(np.linalg.norm(vector[4:6]), np.linalg.norm(original[4:6]), atol=1e-6)
    assert len({tuple(np.round(v[4:6], 4)) for v in augmented.vectors}) > 1
