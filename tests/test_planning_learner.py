"""The planning learner: no prior before a label, the same weights on any map, zero-shot loading, bad input."""

import json
import zipfile

import gymnasium as gym
import numpy as np
import pytest
import torch as th

from antmaze_hirl.dagger import HighLevelPolicy
from antmaze_hirl.dagger.features import EncodedBatch
from antmaze_hirl.dagger.high_level_policy import LearnerSettings, planning_rounds
from antmaze_hirl.dagger.network import (
    BLOCKED_COST,
    NEXT_CELL_MOVES,
    OPEN_BAND,
    REOPENING,
    BlockingSwitch,
    CellValueIteration,
    next_cell_classes,
)
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.experiments.config import learner_settings
from antmaze_hirl.experts.oracle import sample_labelled_states

PLAN = learner_settings("next_cell_plan", 5)
GATE = learner_settings("next_cell_gate", 5)
GATE_PRESSURE = learner_settings("next_cell_gate_pressure", 5)
SWITCH = learner_settings("next_cell_switch", 5)


def point_env(**kwargs):
    return gym.make("antmaze_hirl/PointMaze-v0", low_level=PointGoToController(), **kwargs)


def test_the_untrained_planning_learner_has_no_preference_and_learns_to_trust_its_planner():
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **PLAN)
    obs, _ = env.reset(seed=0)
    batch = learner.encoder.encode_observations([obs])
    logits = learner.network(th.from_numpy(batch.grids), th.from_numpy(batch.vectors))
    assert th.equal(logits, th.zeros_like(logits))  # every move as likely: no goal-seeking prior before a label
    targets = np.array([[1.0, 0.0]], np.float32)
    learner.fit(batch, targets, steps=5)
    assert float(learner.network.trust.detach()) > 0.0


def test_any_map_is_checked_with_the_head_that_uses_it():
    env = point_env(maze_size=3)
    with pytest.raises(ValueError, match="any_map needs head='next_cell' and planning_iterations > 0"):
        HighLevelPolicy.for_env(
            env, rng=np.random.default_rng(0), head="next_cell", planning_iterations=0, block_walls=False, any_map=True
        )


def test_the_planning_learner_acts_on_two_map_sizes_with_the_same_weights(tmp_path):
    small = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(small, rng=np.random.default_rng(0), **PLAN)
    assert learner.runs_on_any_map
    big = point_env(maze_size=7)
    moved = learner.on_map(big.unwrapped.geometry, pixels_per_cell=big.unwrapped.pixels_per_cell)
    geometry = big.unwrapped.geometry
    assert moved.settings.planning_iterations == planning_rounds(geometry.n_rows, geometry.n_cols)
    assert moved.encoder.grid_size > learner.encoder.grid_size
    for key, tensor in learner.network.state_dict().items():
        assert th.equal(tensor, moved.network.state_dict()[key]), key
    for env, policy in ((small, learner), (big, moved)):
        obs, _ = env.reset(seed=1)
        subgoal = policy.predict(obs)
        assert subgoal.shape == (2,) and np.all(np.isfinite(subgoal))
    # Saved and loaded, it is the same learner on the new map.
    loaded = HighLevelPolicy.load(moved.save(tmp_path / "moved.zip"))
    obs, _ = big.reset(seed=2)
    np.testing.assert_array_equal(loaded.predict(obs), moved.predict(obs))


def test_a_cnn_learner_or_another_body_cannot_move_and_says_why():
    small = point_env(maze_size=3)
    cnn = HighLevelPolicy.for_env(small, rng=np.random.default_rng(0), **learner_settings("next_cell_cnn", 3))
    assert not cnn.runs_on_any_map
    big = point_env(maze_size=7).unwrapped.geometry
    with pytest.raises(
        ValueError, match=r"^this learner \(head 'next_cell', any_map False\) sees a 9x9 grid and cannot"
    ):
        cnn.on_map(big)
    plan = HighLevelPolicy.for_env(small, rng=np.random.default_rng(0), **PLAN)
    with pytest.raises(ValueError, match=r"^the map's cells are 4.0 m but this learner's are 1.0 m: another body$"):
        plan.on_map(MazeGeometry(6, 6, 4.0))


def test_the_planner_propagates_over_a_map_larger_than_any_it_trained_on():
    # A corridor of 20 cells, goal at its far end: the hand-set planner needs >= 20 rounds, which on_map gives.
    size = 41
    grids = th.ones((1, 2, size, size))
    grids[:, 1] = 0.0
    centre = size // 2
    grids[:, 0, centre, centre : centre + 21] = 0.0
    grids[:, 1, centre, centre + 20] = 1.0
    planner = CellValueIteration(planning_rounds(22, 22), channels=2)
    with th.no_grad():  # cost 1 a free move, 20 into a wall (as tests/test_next_cell.py's hand-set planner)
        first, second = planner.cost[0], planner.cost[2]
        first.weight.zero_(), first.bias.zero_(), second.weight.zero_()
        first.weight[0, 0, 1, 1] = 1.0
        for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
            second.weight[index, 0, 1 - dy, 1 + dx] = 20.0
        second.bias.fill_(float(np.log(np.e - 1)))
    q = planner(grids)[0].detach()
    assert NEXT_CELL_MOVES[int(q.argmax())] == (1, 0)
    assert float(q.max()) == pytest.approx(-20.0, abs=1e-3)


def detour_map(size: int, detour_cells: int) -> th.Tensor:
    """A wall row between the agent (grid centre) and the goal two rows up; the gap is ``detour_cells`` east."""
    grids = th.ones((1, 2, size, size))
    grids[:, 1] = 0.0
    centre = size // 2
    grids[:, 0, centre - 2 : centre + 1, centre - 1 : centre + detour_cells + 2] = 0.0  # open rows
    grids[:, 0, centre - 1, centre - 1 : centre + detour_cells] = 1.0  # the wall row, open at its east end
    grids[:, 1, centre - 2, centre] = 1.0
    return grids


def hand_set(planner: CellValueIteration, wall_cost: float) -> None:
    """Cost 1 a free move, ``wall_cost`` more into a wall (read from the 3x3 view), as in the test above."""
    with th.no_grad():
        first, second = planner.cost[0], planner.cost[2]
        first.weight.zero_(), first.bias.zero_(), second.weight.zero_()
        first.weight[0, 0, 1, 1] = 1.0
        for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
            second.weight[index, 0, 1 - dy, 1 + dx] = wall_cost
        second.bias.fill_(float(np.log(np.e - 1)))


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("detour_cells", [3, 12])
def test_a_learnt_blocking_gate_prices_a_wall_above_any_detour_where_a_finite_cost_does_not(detour_cells, binary):
    # A wall cost learnt on small mazes (here 6 moves) beats short detours only: on a 12-cell detour the plain
    # planner walks into the wall; with the gate saturated on walls (as labels would push it), or the switch
    # shut on them (its logit above 0), it never does.
    size = 2 * detour_cells + 9
    grids = detour_map(size, detour_cells)
    plain = CellValueIteration(planning_rounds(size, size), channels=2)
    gated = CellValueIteration(planning_rounds(size, size), channels=2, learnt_blocking=True, binary_blocking=binary)
    for planner in (plain, gated):
        hand_set(planner, 6.0)
    with th.no_grad():  # the gate: closed (sigmoid ~ 1) for a move into a wall, open (~ 0) otherwise
        first, second = gated.blocking[0], gated.blocking[2]
        first.weight.zero_(), first.bias.zero_(), second.weight.zero_()
        first.weight[0, 0, 1, 1] = 1.0
        for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
            second.weight[index, 0, 1 - dy, 1 + dx] = 40.0
        second.bias.fill_(-20.0)
    plain_move, gated_move = (NEXT_CELL_MOVES[int(planner(grids)[0].argmax())] for planner in (plain, gated))
    assert gated_move == (1, 0)  # east, towards the gap
    assert (plain_move[1] == 1) == (detour_cells == 12)  # north: into the wall row


def test_learnt_blocking_needs_a_planner_and_excludes_given_walls():
    env = point_env(maze_size=3)
    with pytest.raises(ValueError, match="learnt_blocking needs head='next_cell', planning_iterations > 0 and no"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**GATE, "block_walls": True})
    with pytest.raises(ValueError, match="learnt_blocking needs head='next_cell', planning_iterations > 0"):
        no_planner = {**GATE, "planning_iterations": 0, "any_map": False}
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **no_planner)
    with pytest.raises(ValueError, match="block_walls and learnt_blocking exclude each other"):
        CellValueIteration(3, block_walls=True, learnt_blocking=True)


def untrained_on_a_small_map(settings: dict) -> tuple:
    """A learner of ``settings`` on a 3x3 point maze, a 7x7 one, the learner, and its grids and logits at a reset."""
    small, big = point_env(maze_size=3), point_env(maze_size=7)
    learner = HighLevelPolicy.for_env(small, rng=np.random.default_rng(0), **settings)
    obs, _ = small.reset(seed=0)
    batch = learner.encoder.encode_observations([obs])
    grids = th.from_numpy(batch.grids)
    return small, big, learner, grids, learner.network(grids, th.from_numpy(batch.vectors))


def test_the_gated_learner_starts_without_preference_and_moves_to_a_larger_map(tmp_path):
    _, big, learner, grids, logits = untrained_on_a_small_map(GATE)
    assert th.equal(logits, th.zeros_like(logits))
    # The gate starts as one more move cost of a usual size (BLOCKING_START), not as a block: about 1.2 a move.
    added = BLOCKED_COST * learner.network.planner.blocking(grids)
    assert float(added.max()) < 5.0 and float(added.min()) > 0.1
    moved = learner.on_map(big.unwrapped.geometry, pixels_per_cell=big.unwrapped.pixels_per_cell)
    with th.no_grad():  # a gate of its own, so a reload that dropped or scrambled it would show in the planner's Q
        moved.network.planner.blocking[2].bias.copy_(th.linspace(-6.0, 2.0, len(NEXT_CELL_MOVES)))
    loaded = HighLevelPolicy.load(moved.save(tmp_path / "gate.zip"))
    assert loaded.settings.learnt_blocking and loaded.network.planner.blocking is not None
    obs, _ = big.reset(seed=2)
    big_grids = th.from_numpy(moved.encoder.encode_observations([obs]).grids)
    with th.no_grad():
        assert th.equal(loaded.network.planner(big_grids), moved.network.planner(big_grids))
        without_gate = CellValueIteration(moved.network.planner.iterations, moved.settings.channels)
        without_gate.cost.load_state_dict(moved.network.planner.cost.state_dict())
        assert not th.equal(without_gate(big_grids), moved.network.planner(big_grids))


@pytest.mark.integration  # about 15 s on an idle core (60-90 s on a loaded one)
def test_the_planning_learner_learns_to_plan_from_oracle_labels():
    from script_helpers import load_script

    th.set_num_threads(1)
    # scripts/learning_margins.py planner_gain --seeds 0-9 (2026-12-07, loaded 2-core machine): gain min 0.70,
    # median 0.77, max 0.90, sd 0.075, untrained at most 1 of 30; 0.4 sits four spreads below the lowest seed.
    figures = load_script("scripts/planner_check.py").learning_gain(0)
    assert figures["untrained"] <= 0.2
    assert figures["gain"] >= 0.4


@pytest.mark.parametrize("body", ["point", "ant"])
def test_a_planning_learner_ships_for_each_body_with_its_record(body):
    import hashlib

    from antmaze_hirl.dagger import load_shipped_learner, shipped_learner_path, shipped_learner_record

    record = shipped_learner_record(body)
    assert hashlib.sha256(shipped_learner_path(body).read_bytes()).hexdigest() == record["sha256"]
    assert (record["learner"], record["body"]) == ("next_cell_plan", body)
    assert 300 <= record["labels"] < 320  # "about 300 labels", the first episode past 300
    learner = load_shipped_learner(body)
    assert learner.runs_on_any_map and learner.settings.any_map


def test_benchmark_policy_planner_scores_the_shipped_learner_zero_shot_on_another_map():
    from antmaze_hirl.experiments.benchmark import score_policy

    report = score_policy(
        "point-u", "planner", task_ids=[0], episodes_per_task=1, low_level=lambda obs: np.zeros(2), num_envs=1
    )
    assert report["policy"].startswith("shipped point planning learner sha256:")
    assert report["policy"].endswith("(zero-shot: trained on 7x7 maps)")


def test_no_learner_for_an_unknown_body_is_one_line():
    from antmaze_hirl.dagger import shipped_learner_path

    with pytest.raises(ValueError, match="unknown body 'cat'"):
        shipped_learner_path("cat")


def test_sampled_states_are_free_cells_labelled_by_the_oracle_and_seeded():
    from antmaze_hirl.experts.oracle import plan_subgoal, sample_labelled_states

    env = point_env(maze_size=4)
    first = sample_labelled_states(env, 20, subgoal_reach_m=1.0, rng=np.random.default_rng(3))
    again = sample_labelled_states(env, 20, subgoal_reach_m=1.0, rng=np.random.default_rng(3))
    geometry = env.unwrapped.geometry
    for walls, agent, goal, label in zip(first.walls, first.agents, first.goals, first.labels, strict=True):
        assert not walls[geometry.xy_to_cell(agent)]  # the agent stands in a free cell
        assert geometry.xy_to_cell(agent) != geometry.xy_to_cell(goal)
        np.testing.assert_array_equal(
            label, plan_subgoal(walls, geometry, agent, goal, subgoal_reach_m=1.0, clearance_m=0.2 * geometry.scale)
        )
        assert np.linalg.norm(label - agent) <= 1.0 + 1e-9
    np.testing.assert_array_equal(np.stack(first.agents), np.stack(again.agents))


class FixedMove(th.nn.Module):
    """A network that always picks one move (the rollout only reads the argmax)."""

    def __init__(self, move: tuple[int, int]) -> None:
        super().__init__()
        self.index = NEXT_CELL_MOVES.index(move)

    def forward(self, grids: th.Tensor, vectors: th.Tensor) -> th.Tensor:
        logits = th.zeros((grids.shape[0], len(NEXT_CELL_MOVES)))
        logits[:, self.index] = 1.0
        return logits


@pytest.mark.integration  # a lab check (scripts/planner_check.py)
@pytest.mark.parametrize(
    ("move", "end"),
    [((1, 0), "success"), ((0, 1), "into_wall"), ((1, 1), "past_corner"), ((0, 0), "stay"), ((-1, 0), "into_wall")],
)
def test_a_grid_rollout_names_how_it_ended(move, end):
    from script_helpers import load_script

    planner_check = load_script("scripts/planner_check.py")
    env = point_env(maze_size=3)
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **PLAN)
    policy.network = FixedMove(move)
    walls = np.ones((5, 5), dtype=bool)
    walls[2, 1:4] = False  # a west-east corridor; the goal at its east end
    walls[1, 2] = False  # a free cell north of the corridor's middle: a diagonal from the start passes a corner
    at_rest = np.zeros(2)
    goal_xy = policy.geometry.cell_to_xy((2, 3))
    assert planner_check.rollout_end(policy, walls, (2, 1), (2, 3), at_rest, goal_xy) == end
    assert planner_check.rollout_end(policy, walls, (2, 1), (2, 3), at_rest) == end  # the goal cell's centre
    assert end in planner_check.ENDS


def test_blocking_pressure_is_checked():
    env = point_env(maze_size=3)
    for bad in (-0.5, float("inf"), float("nan")):
        with pytest.raises(ValueError, match=rf"blocking_pressure must be finite and >= 0, got {bad}"):
            HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**GATE, "blocking_pressure": bad})
    with pytest.raises(ValueError, match=r"blocking_pressure needs learnt_blocking, got 1\.0 without it"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**PLAN, "blocking_pressure": 1.0})
    with pytest.raises(ValueError, match="no learnt blocking gate"):
        CellValueIteration(3).blocking_logits(th.zeros((1, 2, 5, 5)))


def gate_after_fit(pressure: float) -> tuple[float, float]:
    """Mean learnt gate on moves into a wall and on the labels' own moves, after the same fit on oracle labels."""
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(
        env, rng=np.random.default_rng(0), **{**GATE_PRESSURE, "blocking_pressure": pressure}
    )
    data = sample_labelled_states(env, 60, subgoal_reach_m=learner.subgoal_reach_m, rng=np.random.default_rng(1))
    batch = learner.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    targets = learner.targets(np.stack(data.agents), np.stack(data.labels))
    learner.fit(batch, targets, steps=150)
    grids = th.from_numpy(batch.grids)
    with th.no_grad():
        gate = learner.network.planner.blocking(grids)
    centre = grids.shape[-1] // 2
    into_wall = th.stack([grids[:, 0, centre - dy, centre + dx] for dx, dy in NEXT_CELL_MOVES], dim=1) > 0.5
    labelled = th.nn.functional.one_hot(th.from_numpy(next_cell_classes(targets)), len(NEXT_CELL_MOVES)).bool()
    at_agent = gate[:, :, centre, centre]
    return float(at_agent[into_wall].mean()), float(at_agent[labelled].mean())


def test_blocking_pressure_prices_moves_into_walls_far_up_and_the_labelled_moves_less():
    # Without the pressure the labels move the gate little from its start; with it the moves into walls, which
    # no label makes, are priced far higher, and the labelled moves less, but not nothing: the pressure pushes
    # them too (its cost, read on the selection mazes in results/planning_learner/selection/looks/).
    # Pressure 1.0 (ten times the named learner's) so that 150 steps show it.
    plain_wall, plain_label = gate_after_fit(0.0)
    pressed_wall, pressed_label = gate_after_fit(1.0)
    assert pressed_wall > 10 * plain_wall
    assert plain_label < pressed_label < pressed_wall


def test_the_switch_adds_the_blocked_cost_or_nothing_and_its_surrogate_blocks_and_reopens_but_does_not_drift():
    logits = th.tensor([-5.0, -1.0, 0.0, 0.5], requires_grad=True)
    assert BlockingSwitch.apply(logits).tolist() == [0.0, 0.0, 0.0, BLOCKED_COST]
    assert -5.0 < -OPEN_BAND < -1.0
    # A cost's gradient of +1 (the loss wants the move cheaper: open it); -1 (dearer: shut it).
    for push, expected in ((1.0, [0.0, 1.0, 1.0, REOPENING]), (-1.0, [-1.0, -1.0, -1.0, -REOPENING])):
        logits.grad = None
        BlockingSwitch.apply(logits).backward(th.full((4,), push))
        assert logits.grad.tolist() == expected, push


def test_binary_blocking_needs_the_learnt_gate():
    env = point_env(maze_size=3)
    with pytest.raises(ValueError, match="binary_blocking needs learnt_blocking: it makes the learnt gate a switch"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**PLAN, "binary_blocking": True})
    with pytest.raises(ValueError, match="binary_blocking needs learnt_blocking"):
        CellValueIteration(3, binary_blocking=True)
    with pytest.raises(ValueError, match="binary_blocking and blocking_pressure exclude each other"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**SWITCH, "blocking_pressure": 0.1})


def test_the_switch_learner_starts_open_without_preference_and_saves_its_switch(tmp_path):
    _, big, learner, grids, logits = untrained_on_a_small_map(SWITCH)
    assert th.equal(logits, th.zeros((1, len(NEXT_CELL_MOVES))))
    assert float(learner.network.planner.blocking_logits(grids).max()) < 0.0  # every move open
    moved = learner.on_map(big.unwrapped.geometry, pixels_per_cell=big.unwrapped.pixels_per_cell)
    with th.no_grad():  # some switches shut, so that a reload that lost the switch (a sigmoid gate) would show
        moved.network.planner.blocking[2].bias.copy_(th.linspace(-2.0, 2.0, len(NEXT_CELL_MOVES)))
        moved.network.trust.fill_(0.5)
    loaded = HighLevelPolicy.load(moved.save(tmp_path / "switch.zip"))
    assert loaded.settings.binary_blocking and loaded.network.planner.binary_blocking
    obs, _ = big.reset(seed=2)
    big_batch = moved.encoder.encode_observations([obs])
    inputs = (th.from_numpy(big_batch.grids), th.from_numpy(big_batch.vectors))
    with th.no_grad():
        assert th.equal(loaded.network(*inputs), moved.network(*inputs))
        assert float(moved.network.planner.blocking_cost(inputs[0]).max()) == BLOCKED_COST
    # A file from before the setting (its config without the key) loads the sigmoid gate.
    with zipfile.ZipFile(tmp_path / "switch.zip") as archive:
        meta, weights = json.loads(archive.read("meta.json")), archive.read("weights.pt")
    del meta["config"]["binary_blocking"]
    with zipfile.ZipFile(tmp_path / "older.zip", "w") as archive:
        archive.writestr("meta.json", json.dumps(meta))
        archive.writestr("weights.pt", weights)
    older = HighLevelPolicy.load(tmp_path / "older.zip")
    assert older.settings.learnt_blocking and not older.network.planner.binary_blocking


FIT_SEEDS = [0, pytest.param(1, marks=pytest.mark.integration)]
"""Seeds of the tests that fit a learner for hundreds of steps (5-7 s a seed): each learnt behaviour is checked on
seed 0 in the unit tier and on seed 1 too in the integration tier (CI runs both); every bound sits outside the
spread of seeds 0-5, so one seed is a check on its own."""


def shut_after_fit(seed: int, settings: dict = SWITCH) -> tuple[float, float, float, float]:
    """Shares of moves shut at the agent's cell, after fitting a switch learner on oracle labels of 3x3 point mazes.

    Moves into a wall before the fit; after it, moves into a wall, the labels' own moves, and the other free moves.
    """
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(env, rng=np.random.default_rng(seed), **settings)
    data = sample_labelled_states(
        env, 100, subgoal_reach_m=learner.subgoal_reach_m, rng=np.random.default_rng(100 + seed)
    )
    batch = learner.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    targets = learner.targets(np.stack(data.agents), np.stack(data.labels))
    grids = th.from_numpy(batch.grids)
    centre = grids.shape[-1] // 2
    into_wall = th.stack([grids[:, 0, centre - dy, centre + dx] for dx, dy in NEXT_CELL_MOVES], dim=1) > 0.5
    labelled = th.nn.functional.one_hot(th.from_numpy(next_cell_classes(targets)), len(NEXT_CELL_MOVES)).bool()

    def shut() -> th.Tensor:
        with th.no_grad():  # a move's switch, per move or its destination cell's (cell_switch)
            return learner.network.planner.blocking_cost(grids)[:, :, centre, centre] > 0

    before = float(shut()[into_wall].float().mean())
    learner.fit(batch, targets, steps=300)
    after = shut()
    free = ~into_wall & ~labelled
    return before, *(float(after[moves].float().mean()) for moves in (into_wall, labelled, free))


@pytest.mark.parametrize("seed", FIT_SEEDS)
def test_the_switch_learns_to_shut_moves_into_walls_and_keeps_the_labelled_moves_open(seed):
    # Measured over seeds 0-5 (uncommitted script, session 28): into a wall 0% shut before, 77-95% after; the
    # labelled moves 0-1% shut after. The bounds sit well outside that spread.
    before, into_wall, labelled, _ = shut_after_fit(seed)
    assert before == 0.0
    assert into_wall > 0.5
    assert labelled < 0.05


def test_switch_flattening_is_checked():
    env = point_env(maze_size=3)
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(ValueError, match=r"switch_flattening must be in \(0, 1\], got"):
            HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**SWITCH, "switch_flattening": bad})
    with pytest.raises(ValueError, match=r"switch_flattening needs binary_blocking and any_map, got 0\.5"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**GATE, "switch_flattening": 0.5})
    with pytest.raises(ValueError, match="switch_readout needs an any_map planner with binary_blocking"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **GATE).network.switch_readout(
            th.zeros((1, 2, 5, 5))
        )


def test_a_flattened_switch_learns_from_a_flatter_softmax_and_the_rest_as_before(tmp_path):
    # At flattening 1 the two cross-entropies give every parameter the one cross-entropy's gradient; at 0.5 the
    # switch's gradient changes and the trust's and costs' do not.
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **learner_settings("next_cell_switch_flat", 5))
    loaded = HighLevelPolicy.load(learner.save(tmp_path / "flat.zip"))
    assert loaded.settings.switch_flattening == learner.settings.switch_flattening == 0.5
    data = sample_labelled_states(env, 40, subgoal_reach_m=learner.subgoal_reach_m, rng=np.random.default_rng(1))
    batch = learner.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    classes = th.from_numpy(next_cell_classes(learner.targets(np.stack(data.agents), np.stack(data.labels))))
    grids, vectors = th.from_numpy(batch.grids), th.from_numpy(batch.vectors)
    network = learner.network
    with th.no_grad():
        network.trust.fill_(0.5)

    def gradients(loss: th.Tensor) -> dict[str, th.Tensor]:
        network.zero_grad()
        loss.backward()
        return {name: p.grad.clone() for name, p in network.named_parameters() if p.grad is not None}

    one = gradients(th.nn.functional.cross_entropy(network(grids, vectors), classes))
    flat = gradients(learner._flattened_switch_loss(grids, classes))
    learner.settings = learner.settings.replace(switch_flattening=1.0)
    same = gradients(learner._flattened_switch_loss(grids, classes))
    switch = {name for name in one if name.startswith("planner.blocking")}
    assert switch and set(one) == set(flat) == set(same)
    for name in one:
        th.testing.assert_close(same[name], one[name])
        if name in switch:
            assert not th.allclose(flat[name], one[name]), name
        else:
            th.testing.assert_close(flat[name], one[name])


def pressure_fit(steps: int, two_passes: bool = False) -> tuple[HighLevelPolicy, float, int]:
    """A pressured gate learner after ``steps`` steps of one seeded fit, its returned loss, and how many times the
    gate's convolutions ran; ``two_passes`` prices the gate with a second pass of them, as the fit did before."""
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**GATE_PRESSURE, "blocking_pressure": 1.0})
    data = sample_labelled_states(env, 30, subgoal_reach_m=learner.subgoal_reach_m, rng=np.random.default_rng(1))
    batch = learner.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    targets = learner.targets(np.stack(data.agents), np.stack(data.labels))
    network = learner.network
    if two_passes:  # the move logits from one pass, the pressure's gate logits from a second
        one_pass = type(network).logits_and_blocking_logits
        network.logits_and_blocking_logits = lambda grids, vectors: (
            one_pass(network, grids, vectors)[0],
            network.planner.blocking_logits(grids),
        )
    passes = []
    network.planner.blocking[0].register_forward_hook(lambda *_: passes.append(1))
    loss = learner.fit(batch, targets, steps=steps)
    return learner, loss, len(passes)


def test_the_blocking_pressure_runs_the_gates_convolutions_once_a_step_with_the_same_loss():
    _, loss, passes = pressure_fit(steps=1)
    assert passes == 1  # the fit ran them twice a step before: once for the logits, once for the pressure
    _, old_loss, old_passes = pressure_fit(steps=1, two_passes=True)
    assert old_passes == 2
    assert loss == old_loss  # the same forward values: only the gradient's sums run in another order
    learner, _, passes = pressure_fit(steps=20)
    old, _, _ = pressure_fit(steps=20, two_passes=True)
    assert passes == 20
    for key, tensor in learner.network.state_dict().items():
        assert th.allclose(tensor, old.network.state_dict()[key], rtol=1e-5, atol=1e-6), key


CELL_SWITCH = learner_settings("next_cell_switch_cell", 5)


def test_cell_switch_needs_the_switch():
    env = point_env(maze_size=3)
    with pytest.raises(ValueError, match="cell_switch needs binary_blocking: it makes the switch one per cell"):
        HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **{**GATE, "cell_switch": True})
    with pytest.raises(ValueError, match="cell_blocking needs binary_blocking"):
        CellValueIteration(3, learnt_blocking=True, cell_blocking=True)


def test_a_cell_switch_blocks_every_move_into_a_shut_cell_and_no_other():
    # Hand-set gate: a cell's logit is +1 where its own cell is a wall, -1 elsewhere. Then every move, from any cell,
    # costs BLOCKED_COST exactly when the cell it leads into is a wall (a per-move or per-source switch would not).
    planner = CellValueIteration(3, learnt_blocking=True, binary_blocking=True, cell_blocking=True)
    assert planner.blocking[2].out_channels == 1
    with th.no_grad():
        for layer in (planner.blocking[0], planner.blocking[2]):
            layer.weight.zero_()
            layer.bias.zero_()
        planner.blocking[0].weight[0, 0, 1, 1] = 1.0  # the wall channel at the cell itself
        planner.blocking[2].weight[0, 0, 1, 1] = 2.0
        planner.blocking[2].bias.fill_(-1.0)
    size = 7
    walls = th.from_numpy(np.random.default_rng(3).random((size, size)) < 0.4).float()
    grids = th.stack([walls, th.zeros_like(walls)])[None]
    with th.no_grad():  # float() of a tensor that requires grad warns
        cost = planner.blocking_cost(grids)[0]
    assert cost.shape == (len(NEXT_CELL_MOVES), size, size)
    for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
        for row in range(size):
            for col in range(size):
                inside = 0 <= row - dy < size and 0 <= col + dx < size
                into_wall = inside and bool(walls[row - dy, col + dx])
                assert float(cost[index, row, col]) == (BLOCKED_COST if into_wall else 0.0), (index, row, col)


def test_the_cell_switch_learner_starts_open_without_preference_and_saves_its_switch(tmp_path):
    small, _, learner, grids, logits = untrained_on_a_small_map(CELL_SWITCH)
    assert th.equal(logits, th.zeros((1, len(NEXT_CELL_MOVES))))
    assert float(learner.network.planner.blocking_logits(grids).max()) < 0.0  # every cell open
    loaded = HighLevelPolicy.load(learner.save(tmp_path / "cell.zip"))
    assert loaded.settings.cell_switch and loaded.network.planner.cell_blocking
    with th.no_grad():
        assert th.equal(loaded.network.planner.blocking_logits(grids), learner.network.planner.blocking_logits(grids))
    # A file from before the setting (a per-move switch's, its config without the key) loads a per-move switch.
    older = HighLevelPolicy.for_env(small, rng=np.random.default_rng(0), **SWITCH)
    with zipfile.ZipFile(older.save(tmp_path / "switch.zip")) as archive:
        meta, weights = json.loads(archive.read("meta.json")), archive.read("weights.pt")
    del meta["config"]["cell_switch"]
    with zipfile.ZipFile(tmp_path / "older.zip", "w") as archive:
        archive.writestr("meta.json", json.dumps(meta))
        archive.writestr("weights.pt", weights)
    assert not HighLevelPolicy.load(tmp_path / "older.zip").network.planner.cell_blocking


@pytest.mark.parametrize("seed", FIT_SEEDS)
def test_the_cell_switch_learns_to_shut_walls_and_keeps_free_cells_open(seed):
    # Measured over seeds 0-5 (session 29; `PYTHONPATH=.:tests python -c "from test_planning_learner import
    # shut_after_fit as f, CELL_SWITCH as c; [print(s, f(s, c)) for s in range(6)]"`): into a wall 0% shut
    # before, 99.8-100% after; the labelled moves 0%; the other free moves 0-5.2%. The bounds sit outside that spread.
    before, into_wall, labelled, free = shut_after_fit(seed, CELL_SWITCH)
    assert before == 0.0
    assert into_wall > 0.8
    assert labelled < 0.05
    assert free < 0.2


def test_experience_blocking_weight_needs_the_switch_and_is_checked():
    with pytest.raises(ValueError, match="experience_blocking_weight needs binary_blocking"):
        LearnerSettings(**{**learner_settings("next_cell_gate", 3), "experience_blocking_weight": 1.0})
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="experience_blocking_weight must be finite"):
            LearnerSettings(**{**SWITCH, "experience_blocking_weight": bad})


def switch_after_outcomes(seed: int, weight: float, steps: int = 150) -> tuple[float, float, float, float]:
    """Shares of recorded moves shut, before and after fitting a switch learner on labels and outcome records.

    Records crafted from oracle-labelled states of 3x3 point mazes: each straight move from each state, blocked
    where it leads into a wall, else made (diagonals left out: whether a body squeezes past a wall's corner is the
    body's). Returns blocked moves shut before and after the fit, and made moves shut before and after.
    """
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(
        env, rng=np.random.default_rng(seed), **{**SWITCH, "experience_blocking_weight": weight}
    )
    data = sample_labelled_states(
        env, 100, subgoal_reach_m=learner.subgoal_reach_m, rng=np.random.default_rng(100 + seed)
    )
    batch = learner.encoder.encode(data.walls, data.agents, data.goals, data.bodies)
    centre = batch.grids.shape[-1] // 2
    moves = [(dx, dy) for dx, dy in NEXT_CELL_MOVES if abs(dx) + abs(dy) == 1]
    steps_tried = np.array([move for _ in range(len(batch)) for move in moves], dtype=np.float32)
    tried = EncodedBatch(np.repeat(batch.grids, len(moves), axis=0), np.repeat(batch.vectors, len(moves), axis=0))
    blocked = np.array([grid[0, centre - dy, centre + dx] > 0.5 for grid in batch.grids for dx, dy in moves])
    learner.outcomes.add(tried, steps_tried, blocked)
    classes = th.from_numpy(next_cell_classes(steps_tried))

    def shut() -> np.ndarray:
        with th.no_grad():
            logits = learner.network.planner.blocking_logits(th.from_numpy(tried.grids))[:, :, centre, centre]
        return (logits.gather(1, classes[:, None])[:, 0] > 0).numpy()

    before = shut()
    learner.fit(batch, learner.targets(np.stack(data.agents), np.stack(data.labels)), steps=steps)
    after = shut()
    return (
        float(before[blocked].mean()),
        float(after[blocked].mean()),
        float(before[~blocked].mean()),
        float(after[~blocked].mean()),
    )


@pytest.mark.parametrize("seed", FIT_SEEDS)
def test_moves_recorded_blocked_are_shut_and_moves_recorded_made_open_by_the_experience_term(seed):
    # Measured over seeds 0-5 by an uncommitted script (session 29): with the term 97.6-100% of the blocked moves shut
    # and 1.0-7.7% of the made ones; without it (the labels alone, 150 steps) 0-2.3% of the blocked moves shut.
    with_term = switch_after_outcomes(seed, 1.0)
    without = switch_after_outcomes(seed, 0.0)
    assert with_term[0] == 0.0 and with_term[2] == 0.0  # every switch starts open
    assert with_term[1] > 0.9
    assert with_term[3] < 0.15
    assert without[1] < 0.2  # the labels alone do not shut them


def test_a_step_is_recorded_blocked_when_its_walk_missed_the_cell_and_made_when_it_entered_it():
    env = point_env(maze_size=3)
    learner = HighLevelPolicy.for_env(
        env, rng=np.random.default_rng(0), **{**SWITCH, "experience_blocking_weight": 1.0}
    )
    observation, _ = env.reset(seed=0)
    geometry = learner.geometry
    start = np.asarray(observation["state"][:2], dtype=np.float64)
    east = start + np.array([geometry.scale, 0.0])
    missed = {"agent_path": [start, start], "subgoal_reached": False, "flipped": False, "is_success": False}
    entered = {**missed, "agent_path": [start, east]}
    learner.observe_step(observation, east, missed)
    learner.observe_step(observation, east, entered)
    learner.observe_step(observation, east, {**missed, "subgoal_reached": True})  # reached short of it: no record
    learner.observe_step(observation, east, {**missed, "flipped": True})  # a fall: no record
    learner.observe_step(observation, start, missed)  # a stay: no record
    _, steps, blocked = learner.outcomes.arrays()
    assert steps.tolist() == [[1.0, 0.0], [1.0, 0.0]]
    assert blocked.tolist() == [1.0, 0.0]
    plain = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0), **SWITCH)
    plain.observe_step(observation, east, missed)
    assert len(plain.outcomes) == 0  # weight 0: nothing recorded


def test_the_trainer_hands_every_executed_step_to_the_learners_observe_step():
    from antmaze_hirl import PathOracle
    from antmaze_hirl.dagger import DAggerTrainer

    env = point_env(maze_size=3)
    rng = np.random.default_rng(0)
    learner = HighLevelPolicy.for_env(env, rng=rng, **{**SWITCH, "experience_blocking_weight": 1.0})
    seen = []
    observe_step = learner.observe_step

    def recording(observation, subgoal, info):
        seen.append(info["agent_path"])
        observe_step(observation, subgoal, info)

    learner.observe_step = recording
    trainer = DAggerTrainer(env=env, expert=PathOracle.for_env(env), learner=learner, rng=rng, gradient_steps=1)
    record = trainer.run_episode()
    assert len(seen) == record.attempts > 0  # one call per executed subgoal, with its walk
    assert len(learner.outcomes) > 0  # and the learner kept what its moves did
