"""The next-cell head: value iteration over crafted grids, label conversion, subgoals, symmetry and persistence."""

import gymnasium as gym
import numpy as np
import pytest
import torch as th

from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy, LearnerSettings
from antmaze_hirl.dagger.features import EncodedBatch, augment
from antmaze_hirl.dagger.network import NEXT_CELL_MOVES, CellValueIteration, blocked_moves, next_cell_classes
from antmaze_hirl.envs import PointGoToController
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experts.oracle import PathOracle

SIZE = 13
CENTRE = SIZE // 2


def unit_cost_planner(iterations=16):
    """A planner whose cost is 1 per move into a free cell and about 20 into a wall (weights set by hand)."""
    planner = CellValueIteration(iterations, channels=2)
    first, second = planner.cost[0], planner.cost[2]
    with th.no_grad():
        first.weight.zero_()
        first.bias.zero_()
        first.weight[0, 0, 1, 1] = 1.0  # hidden channel 0: the cell is a wall
        second.weight.zero_()
        for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
            second.weight[index, 0, 1 - dy, 1 + dx] = 20.0  # the move's target cell is a wall
        second.bias.fill_(float(np.log(np.e - 1)))  # softplus(bias) = 1: a free move costs one
    return planner


def crafted_grid(free_cells, goal):
    grid = np.ones((2, SIZE, SIZE), np.float32)
    grid[1] = 0.0
    for row, col in free_cells:
        grid[0, row, col] = 0.0
    grid[1][goal] = 1.0
    return th.from_numpy(grid[None])


@pytest.mark.parametrize("mirror", [False, True])
def test_value_iteration_takes_the_first_move_of_the_shortest_path_round_a_wall(mirror):
    # The goal is two rows straight above the agent, behind a wall: the path goes round it, east
    # (or west, mirrored), although the goal lies north.
    side = -1 if mirror else 1
    path = [(CENTRE, CENTRE), (CENTRE, CENTRE + side), (CENTRE, CENTRE + 2 * side)]
    path += [(CENTRE - 1, CENTRE + 2 * side), (CENTRE - 2, CENTRE + 2 * side), (CENTRE - 2, CENTRE + side)]
    path += [(CENTRE - 2, CENTRE)]
    q = unit_cost_planner()(crafted_grid(path, (CENTRE - 2, CENTRE)))[0].detach()
    assert NEXT_CELL_MOVES[int(q.argmax())] == (side, 0)
    # Four moves: these hand-set costs let diagonals cut the wall's corners (a learnt cost can price them).
    assert float(q.max()) == pytest.approx(-4.0)


def test_value_iteration_needs_enough_rounds_to_see_the_goal():
    corridor = [(CENTRE, CENTRE - k) for k in range(6)]
    grid = crafted_grid(corridor, (CENTRE, CENTRE - 5))
    assert NEXT_CELL_MOVES[int(unit_cost_planner(6)(grid)[0].argmax())] == (-1, 0)
    blind = unit_cost_planner(3)(grid)[0].detach()  # the goal is 5 moves away: no move has a finite value yet
    assert float(blind.max()) < -100
    with pytest.raises(ValueError, match="iterations must be >= 1, got 0"):
        CellValueIteration(0)


def test_walls_block_moves_into_them_and_diagonals_between_two():
    walls = th.zeros(1, 5, 5)
    walls[0, 1, 2] = 1.0  # north of the centre (2, 2)
    walls[0, 2, 1] = 1.0  # and west of it
    blocked = blocked_moves(walls)[0, :, 2, 2]
    assert {NEXT_CELL_MOVES[k] for k in np.flatnonzero(blocked.numpy())} == {(0, 1), (-1, 0), (-1, 1)}
    assert blocked_moves(walls)[0, NEXT_CELL_MOVES.index((1, 1)), 0, 4] == 1.0  # off the grid counts as wall


def test_blocking_walls_keeps_a_learnt_planner_off_a_cheap_wall():
    planner = unit_cost_planner()
    with th.no_grad():
        planner.cost[2].weight.zero_()  # walls cost no more than free cells: the shortcut runs through one
    free = [(CENTRE, CENTRE), (CENTRE, CENTRE + 1), (CENTRE - 1, CENTRE + 1), (CENTRE - 2, CENTRE + 1)]
    free += [(CENTRE - 2, CENTRE)]
    grid = crafted_grid(free, (CENTRE - 2, CENTRE))
    dx, dy = NEXT_CELL_MOVES[int(planner(grid)[0].argmax())]
    assert grid[0, 0, CENTRE - dy, CENTRE + dx] == 1.0  # a shortest "path" through the walls
    planner.block_walls = True
    assert NEXT_CELL_MOVES[int(planner(grid)[0].argmax())] == (1, 1)  # round it, past one wall's corner


def point_policy(**kwargs):
    geometry = MazeGeometry(7, 7, 1.0)
    settings = LearnerSettings(**kwargs)
    return HighLevelPolicy(geometry, pixels_per_cell=4, body_dim=2, rng=np.random.default_rng(0), settings=settings)


def test_labels_become_the_cell_step_to_the_subgoals_cell():
    policy = point_policy(head="next_cell")
    centre = policy.geometry.cell_to_xy((3, 3))
    agents = np.stack([centre, centre, centre + np.array([0.3, 0.0]), centre, np.array([-3.6, 0.0])])
    subgoals = np.stack(
        [
            centre + np.array([0.0, 1.0]),  # north
            centre + np.array([0.7, -0.7]),  # south-east, one metre along the diagonal
            centre + np.array([0.1, 0.0]),  # back to its own cell's centre
            centre + np.array([0.0, -2.0]),  # two cells south: clipped to one step
            np.array([-2.5, 0.0]),  # agent pressed into the border: its cell is clipped to the map's
        ]
    )
    steps = policy.cell_steps(agents, subgoals)
    np.testing.assert_array_equal(steps, [[0, 1], [1, -1], [0, 0], [0, -1], [1, 0]])
    np.testing.assert_array_equal(next_cell_classes(steps), [7, 2, 4, 1, 5])
    assert [NEXT_CELL_MOVES[k] for k in next_cell_classes(steps)] == [tuple(s) for s in steps.astype(int)]


def test_next_cell_subgoals_are_cell_centres_or_the_goal_within_reach():
    policy = point_policy(head="next_cell")
    walls = np.zeros((7, 7), bool)
    agent = policy.geometry.cell_to_xy((3, 3)) + np.array([0.2, 0.1])
    goal = policy.geometry.cell_to_xy((2, 3)) + np.array([0.1, -0.2])  # off-centre, one cell north
    batch = policy.encoder.encode([walls], [agent], [goal], [np.zeros(2)])
    north, east, north_east = (NEXT_CELL_MOVES.index(move) for move in ((0, 1), (1, 0), (1, 1)))
    to_goal = policy.cell_offsets(batch, np.array([north]))[0] * policy.subgoal_reach_m
    np.testing.assert_allclose(to_goal, goal - agent, atol=1e-6)  # the goal itself, not its cell's centre
    to_east = policy.cell_offsets(batch, np.array([east]))[0] * policy.subgoal_reach_m
    np.testing.assert_allclose(to_east, [0.8, -0.1], atol=1e-6)
    diagonal = policy.cell_offsets(batch, np.array([north_east]))[0]
    assert np.linalg.norm(diagonal) == pytest.approx(1.0)  # pulled back to subgoal_reach_m, like the oracle


def test_symmetries_map_cell_steps_as_they_map_the_grid():
    policy = point_policy(head="next_cell")
    walls = np.zeros((7, 7), bool)
    agent = policy.geometry.cell_to_xy((3, 3))
    goal = policy.geometry.cell_to_xy((2, 4))  # north-east
    batch = policy.encoder.encode([walls] * 64, [agent] * 64, [goal] * 64, [np.zeros(2)] * 64)
    steps = np.tile([[1.0, 1.0]], (64, 1)).astype(np.float32)
    moved, labels = augment(batch, steps, np.random.default_rng(0), planar_feature_dim=policy.planar_feature_dim)
    for grid, label in zip(moved.grids, next_cell_classes(labels), strict=True):
        dx, dy = NEXT_CELL_MOVES[label]
        assert grid[1, CENTRE - dy, CENTRE + dx] == 1.0  # the label still points at the goal
    assert isinstance(moved, EncodedBatch)


def test_unknown_head_and_negative_iterations_are_refused():
    with pytest.raises(ValueError, match=r"head must be one of \['heading', 'next_cell'\], got 'cells'"):
        point_policy(head="cells")
    with pytest.raises(ValueError, match="planning_iterations must be >= 0, got -1"):
        point_policy(planning_iterations=-1)
    with pytest.raises(ValueError, match="block_walls needs head='next_cell' and planning_iterations > 0"):
        point_policy(head="next_cell", block_walls=True)


@pytest.mark.parametrize(("planning_iterations", "block_walls"), [(0, False), (6, False), (6, True)])
def test_next_cell_policy_trains_saves_and_loads(tmp_path, planning_iterations, block_walls):
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, min_goal_cells=2, low_level=PointGoToController())
    rng = np.random.default_rng(0)
    policy = HighLevelPolicy.for_env(
        env, rng=rng, head="next_cell", planning_iterations=planning_iterations, block_walls=block_walls
    )
    trainer = DAggerTrainer(env=env, expert=PathOracle.for_env(env), learner=policy, rng=rng, gradient_steps=10)
    trainer.run_episode()
    assert trainer.learner.gradient_steps == 10
    loaded = HighLevelPolicy.load(trainer.learner.save(tmp_path / "high.zip"))
    assert loaded.config() == trainer.learner.config()
    assert (loaded.config()["head"], loaded.config()["block_walls"]) == ("next_cell", block_walls)
    obs, _ = env.reset(seed=3)
    np.testing.assert_array_equal(loaded.predict(obs), trainer.learner.predict(obs))
    spawned = trainer.learner.spawn(np.random.default_rng(1))
    assert spawned.config() == trainer.learner.config()


def test_each_body_defaults_to_its_ablations_next_cell_head():
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=5, low_level=PointGoToController())
    policy = HighLevelPolicy.for_env(env, rng=np.random.default_rng(0))
    assert (policy.config()["head"], policy.config()["planning_iterations"]) == ("next_cell", 16)
    assert policy.config()["block_walls"]
    previous = HighLevelPolicy.for_env(
        env, rng=np.random.default_rng(0), head="heading", planning_iterations=0, block_walls=False
    )
    assert (previous.config()["head"], previous.config()["planning_iterations"]) == ("heading", 0)
    assert LearnerSettings.for_body("ant", MazeGeometry(6, 6, 4.0)) == LearnerSettings(head="next_cell")


def test_an_ant_policy_takes_the_cnn_next_cell_head_and_trains(still_controller):
    env = gym.make("antmaze_hirl/AntMaze-v0", maze_size=3, low_level=still_controller, max_steps=300)
    rng = np.random.default_rng(0)
    policy = HighLevelPolicy.for_env(env, rng=rng, subgoal_reach_m=2.0)
    assert (policy.config()["head"], policy.config()["planning_iterations"], policy.config()["block_walls"]) == (
        "next_cell",
        0,
        False,
    )
    trainer = DAggerTrainer(
        env=env, expert=PathOracle.for_env(env, subgoal_reach_m=2.0), learner=policy, rng=rng, gradient_steps=5
    )
    trainer.run_episode()  # labels, then the update
    assert trainer.learner.gradient_steps == 5 and len(trainer.dataset) > 0
    observation, _ = env.reset(seed=1)
    subgoal = trainer.learner.predict(observation)
    # within the oracle's reach
    assert np.linalg.norm(subgoal - STATE_LAYOUT.agent_xy(observation["state"])) <= 2.0 + 1e-6


def test_labels_at_a_reach_shorter_than_a_cell_point_on_into_the_next_cell():
    # The ant's oracle gives 2 m subgoals in 4 m cells: one from near a cell's centre ends inside that cell.
    geometry = MazeGeometry(6, 6, 4.0)
    settings = LearnerSettings(subgoal_reach_m=2.0, head="next_cell")
    policy = HighLevelPolicy(geometry, pixels_per_cell=8, body_dim=27, rng=np.random.default_rng(0), settings=settings)
    centre = geometry.cell_to_xy((2, 2))
    agents = np.stack([centre] * 4 + [centre + np.array([0.5, 0.0])])
    subgoals = np.stack(
        [
            centre + np.array([2.0, 0.0]),  # at the reach, east: the path goes on east
            centre + np.array([1.2, 1.2]) * 1.1,  # at the reach, north-east (1.87 m, a little short of 2 m)
            centre + np.array([1.0, 0.0]),  # well short of the reach: a point in its own cell (the goal, say)
            centre + np.array([0.0, -1.7]),  # below 0.9 of the reach: stays a point in its own cell
            centre,  # back to its own cell's centre from 0.5 m east of it
        ]
    )
    np.testing.assert_array_equal(policy.cell_steps(agents, subgoals), [[1, 0], [1, 1], [0, 0], [0, 0], [0, 0]])


def test_the_experiment_gives_the_learner_its_oracles_reach():
    from antmaze_hirl.experiments.config import ExperimentConfig
    from antmaze_hirl.experiments.runner import make_trainer

    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, low_level=PointGoToController())
    oracle = PathOracle.for_env(env, subgoal_reach_m=0.6)
    trainer = make_trainer("dagger", 0, ExperimentConfig(body="point", subgoal_reach_m=0.6), env, oracle)
    assert trainer.learner.subgoal_reach_m == pytest.approx(0.6)
    default = make_trainer("dagger", 0, ExperimentConfig(body="point"), env, PathOracle.for_env(env))
    assert default.learner.subgoal_reach_m == pytest.approx(env.unwrapped.geometry.scale)
    env.close()
