"""The paper's algorithms as written beside this project's variants: Alg. 4 per step, Alg. 2's
shared noise buffer, the ensemble's stated settings, and the AggreVaTe baseline."""

import dataclasses
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import TINY_PROTOCOL1, make_point_trainer

from antmaze_hirl.cli import main
from antmaze_hirl.dagger import (
    AggreVaTeQuery,
    InverseDecayBetaSchedule,
    MultiPolicyQuery,
    NoiseQuery,
    RewardPerStepQuery,
)
from antmaze_hirl.dagger.features import ObservationEncoder
from antmaze_hirl.dagger.network import direction_bins
from antmaze_hirl.dagger.strategies import (
    STRATEGIES,
    StartQuery,
    cost_to_go,
    make_strategy,
    spread,
)
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experiments.config import ExperimentConfig
from antmaze_hirl.experiments.runner import run_trial

GEOMETRY = MazeGeometry(5, 5, 1.0)
# The goal is in (1, 1); from the bottom corridor it is 6 cells away round the wall, 2 as the crow flies.
WALLS = np.array(
    [
        [1, 1, 1, 1, 1],
        [1, 0, 0, 0, 1],
        [1, 1, 1, 0, 1],
        [1, 0, 0, 0, 1],
        [1, 1, 1, 1, 1],
    ],
    dtype=bool,
)
GOAL = GEOMETRY.cell_to_xy((1, 1))
TINY = dataclasses.replace(TINY_PROTOCOL1, episodes=2, eval_episodes=1, final_eval_episodes=1, gradient_steps=2)


def test_new_methods_are_strategies():
    assert STRATEGIES["reward_per_step"] is RewardPerStepQuery and STRATEGIES["aggrevate"] is AggreVaTeQuery
    assert make_strategy("reward_per_step").updates_every_step and not make_strategy("reward").updates_every_step


# --- Alg. 4 as written ---


@pytest.mark.parametrize(("step_gradient_steps", "per_update"), [(None, 3), (2, 2)])
def test_reward_per_step_updates_and_decays_beta_after_every_step(step_gradient_steps, per_update):
    trainer = make_point_trainer(
        RewardPerStepQuery(step_gradient_steps), gradient_steps=3, beta_schedule=InverseDecayBetaSchedule(2.0)
    )
    env = trainer.env
    executed, labels = [], []
    step = env.step

    def recording_step(action):
        executed.append(np.array(action))
        return step(action)

    expert_label = trainer.expert.label

    def recording_label(obs):
        # The beta and learner proposal of this step, seen before its update.
        labels.append(
            (expert_label(obs), trainer.learner.predict(obs), STATE_LAYOUT.agent_xy(obs["state"]), trainer.beta)
        )
        return labels[-1][0]

    env.step, trainer.expert.label = recording_step, recording_label
    first = trainer.run_episode()
    assert first.beta == 1.0
    assert trainer.updates == first.expert_cost and trainer.learner.gradient_steps == per_update * first.expert_cost
    assert [beta for *_, beta in labels] == [0.5**k for k in range(first.expert_cost)]
    for action, (expert, learner, agent, beta) in zip(executed, labels, strict=True):
        mix = np.clip(beta * expert + (1 - beta) * learner, env.action_space.low, env.action_space.high)
        no_op = np.linalg.norm(mix - agent) < env.unwrapped.min_subgoal_distance_m
        np.testing.assert_allclose(action, expert if no_op else mix)
    second = trainer.run_episode()
    # No episode-end update: every update is a step's.
    assert second.beta == 0.5**first.expert_cost
    assert trainer.updates == first.expert_cost + second.expert_cost
    with pytest.raises(ValueError, match="step_gradient_steps must be >= 1, got 0"):
        RewardPerStepQuery(0)


def test_per_episode_methods_keep_one_update_per_episode():
    trainer = make_point_trainer(make_strategy("reward"), gradient_steps=3)
    record = trainer.run_episode()
    assert trainer.updates == 1 and trainer.learner.gradient_steps == 3 and record.expert_cost > 1


# --- Alg. 2's noise buffer ---


class BodyEcho:
    """A policy whose offsets are the body observation, recording every batch it is asked about."""

    def __init__(self):
        self.encoder = ObservationEncoder(GEOMETRY, pixels_per_cell=4)
        self.bodies = []

    def offsets(self, batch):
        self.bodies.append(batch.vectors[:, 4:6].copy())
        return batch.vectors[:, 4:6]


def noise_query(policy):
    candidates = np.stack([GEOMETRY.cell_to_xy(cell) for cell in [(3, 1), (3, 2), (3, 3), (1, 3)]])
    return StartQuery(WALLS, GOAL, candidates, np.array([0.3, -0.2]), policy)


def test_shared_noise_applies_one_buffer_to_every_candidate():
    policy = BodyEcho()
    query = noise_query(policy)
    scores = NoiseQuery(n_noises=6, signal="offsets", symmetries=False).scores(query, np.random.default_rng(0))
    blocks = policy.bodies[-1].reshape(4, 6, 2)
    for block in blocks[1:]:
        np.testing.assert_array_equal(block, blocks[0])
    assert len({tuple(row) for row in blocks[0]}) == 6  # six different perturbations in the buffer
    np.testing.assert_allclose(scores, spread(blocks[0]))


def test_fresh_noise_reproduces_the_old_scores():
    query = noise_query(BodyEcho())
    scores = NoiseQuery(n_noises=6, shared_noise=False, signal="offsets", symmetries=False).scores(
        query, np.random.default_rng(3)
    )
    # The scores before the faithful variants: one uniform draw of shape (candidates, noises, body).
    rng = np.random.default_rng(3)
    noisy = query.body_observation + rng.uniform(-1.0, 1.0, size=(4, 6, 2))
    outputs = query.learner.offsets(query.encode(np.repeat(query.candidates, 6, axis=0), noisy.reshape(-1, 2)))
    expected = [spread(block) for block in outputs.reshape(4, 6, 2)]
    np.testing.assert_array_equal(scores, expected)
    assert len(set(scores)) == 4
    with pytest.raises(ValueError, match="noise_scale must be >= 0, got -1"):
        NoiseQuery(noise_scale=-1)


# --- the ensemble's stated settings ---


def test_multi_policy_defaults_are_the_stated_ones():
    strategy = make_strategy("multi_policy")
    assert isinstance(strategy, MultiPolicyQuery)
    assert strategy.n_policies == 5 and strategy.member_steps is None
    assert "ceil(N / 5)" in MultiPolicyQuery.__doc__ and "40 at the experiments' N = 200" in MultiPolicyQuery.__doc__
    assert ExperimentConfig().gradient_steps == 200


# --- AggreVaTe ---


def test_cost_to_go_is_the_grid_shortest_path():
    centre = GEOMETRY.cell_to_xy
    assert cost_to_go(WALLS, GEOMETRY, GOAL, centre((3, 1))) == 6.0  # round the wall, not 2 across it
    assert cost_to_go(WALLS, GEOMETRY, GOAL, centre((1, 3))) == 2.0
    assert cost_to_go(WALLS, GEOMETRY, GOAL, centre((3, 1)) + np.array([0.3, 0.4])) == pytest.approx(6.5)
    assert cost_to_go(WALLS, GEOMETRY, GOAL, GOAL + np.array([0.3, 0.4])) == pytest.approx(
        0.5
    )  # within the goal's cell
    assert cost_to_go(WALLS, GEOMETRY, GOAL, centre((2, 1))) == math.inf  # a wall
    cut_off = WALLS.copy()
    cut_off[2, 3] = True
    assert cost_to_go(cut_off, GEOMETRY, GOAL, centre((3, 1))) == math.inf


def aggrevate_maze():
    """What AggreVaTe's label_target reads of the trainer's maze env: the layout, geometry and goal."""
    return SimpleNamespace(layout=SimpleNamespace(walls=WALLS), geometry=GEOMETRY, goal_xy=GOAL)


def test_aggrevate_trains_towards_the_lowest_cost_heading():
    agent = GEOMETRY.cell_to_xy((3, 2))
    strategy = AggreVaTeQuery(n_directions=16)
    candidates, costs = strategy.candidate_costs(WALLS, GEOMETRY, GOAL, agent, 1.0)
    # Right leads round the wall (1 + 4), left into the dead end (1 + 6), up through a wall.
    assert costs[0] == 5.0 and costs[8] == 7.0 and costs[4] == math.inf and int(np.argmin(costs)) == 0
    # The expert's subgoal points left (a bad label here): D stores the right-hand heading instead.
    state = STATE_LAYOUT.compose(agent, GOAL, np.zeros(2))
    target = strategy.label_target(aggrevate_maze(), {"state": state}, agent + np.array([-1.0, 0.0]))
    np.testing.assert_allclose(target, candidates[0])
    assert direction_bins((target - agent)[None], 16)[0] == 0
    with pytest.raises(ValueError, match="n_directions must be >= 4, got 2"):
        AggreVaTeQuery(n_directions=2)


def test_aggrevate_takes_the_learners_bins_and_labels_once_per_state():
    trainer = make_point_trainer(make_strategy("aggrevate"), gradient_steps=1)
    assert trainer.strategy.n_directions == trainer.learner.settings.n_directions
    record = trainer.run_episode()
    assert len(trainer.dataset) == record.expert_cost == trainer.total_expert_cost
    offsets = trainer.dataset.subgoals() - trainer.dataset.agent_xy()
    angles = np.arctan2(offsets[:, 1], offsets[:, 0]) / (2 * np.pi / trainer.strategy.n_directions)
    np.testing.assert_allclose(angles, np.round(angles), atol=1e-9)  # every label is a heading bin


# --- through the experiment runner and the CLI ---


@pytest.mark.integration
@pytest.mark.parametrize("method", ["reward_per_step", "aggrevate"])
def test_new_methods_run_a_point_trial(method):
    rows = run_trial(method, 0, TINY)
    assert [row["method"] for row in rows] == [method] * 2 and rows[0]["beta"] == 1.0
    decayed = 0.5 ** rows[0]["expert_cost"] if method == "reward_per_step" else 0.5
    assert rows[1]["beta"] == decayed and 0.0 <= rows[1]["eval_success"] <= 1.0


def test_the_experiment_sets_the_per_step_gradient_budget_of_alg_4():
    from antmaze_hirl.experiments.runner import make_env, make_trainer
    from antmaze_hirl.experts import PathOracle

    env = make_env(TINY)
    trainers = {
        steps: make_trainer("reward_per_step", 0, dataclasses.replace(TINY, step_gradient_steps=steps), env, None)
        for steps in (7, None)
    }
    assert trainers[7].strategy.step_gradient_steps == 7 and trainers[None].strategy.step_gradient_steps is None
    assert make_trainer("reward", 0, TINY, env, PathOracle.for_env(env)).strategy.step_gradient_steps is None
    with pytest.raises(ValueError, match="step_gradient_steps must be >= 1 or None, got 0"):
        dataclasses.replace(TINY, step_gradient_steps=0)


@pytest.mark.integration
def test_cli_accepts_the_new_methods(tmp_path):
    args = ["experiment", "--methods", "reward_per_step,aggrevate", "--seeds", "1", "--episodes", "1"]
    args += ["--eval-every", "1", "--eval-episodes", "1", "--final-eval-episodes", "1", "--maze-size", "3"]
    args += ["--gradient-steps", "1", "--out", str(tmp_path), "--no-progress", "--no-tensorboard"]
    assert main(args) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert set(summary["methods"]) == {"reward_per_step", "aggrevate"}
