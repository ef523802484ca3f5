"""antmaze_lab.in_maze_protocol: step limits, outcome classes and a scaled-limit episode."""

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from conftest import StillController

from antmaze_hirl import rollout
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_hirl.experts import PathOracle
from antmaze_lab import in_maze_protocol as in_maze

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.in_maze_protocol): the integration tier


def test_step_limit_scales_with_the_shortest_path_around_walls():
    walls = validate_maze_map("u")  # rows 1-3 free, a wall at (2, 1)-(2, 2): the path goes round it
    assert in_maze.step_limit(walls, (1, 1), (3, 1), 4.0) == 6 * 4 * in_maze.STEPS_PER_METRE  # 6 grid steps, 24 m
    assert in_maze.step_limit(walls, (1, 1), (1, 2), 4.0) == in_maze.MIN_STEPS  # 4 m: the floor


def test_is_frozen_looks_at_the_last_subgoals_only():
    still = [np.full((3, 2), 5.0) for _ in range(5)]
    walked = [np.array([[0.0, 0.0], [4.0, 0.0]]), *still]
    assert in_maze.is_frozen(walked)  # the walk was 6 subgoals ago
    assert not in_maze.is_frozen(walked, subgoals=6)
    assert not in_maze.is_frozen([np.array([[0.0, 0.0], [0.6, 0.0], [0.0, 1.0]])])
    with pytest.raises(ValueError, match="at least one subgoal, got none"):
        in_maze.is_frozen([])


def test_outcomes_are_exclusive_success_first_then_flip():
    still, moving = [np.zeros((2, 2))], [np.array([[0.0, 0.0], [3.0, 0.0]])]
    assert in_maze.outcome({"is_success": True, "flipped": True}, still) == "success"
    assert in_maze.outcome({"is_success": False, "flipped": True}, still) == "flip"
    assert in_maze.outcome({"is_success": False, "flipped": False}, still) == "frozen"
    assert in_maze.outcome({"is_success": False, "flipped": False}, moving) == "timeout"
    # One vocabulary: the in-maze outcomes are the episode outcomes (rollout.OUTCOMES) but "ended".
    assert in_maze.OUTCOMES == ("success", "flip", "frozen", "timeout")
    assert set(in_maze.OUTCOMES) == set(rollout.OUTCOMES) - {"ended"}


def test_a_still_ant_on_the_u_map_runs_out_of_its_scaled_budget_frozen():
    env = in_maze.MazeEpisodeRecorder(
        gym.make("antmaze_hirl/AntMaze-v0", maze_map="u", low_level=StillController()), scale_step_limit=True
    )
    figures = in_maze.evaluate_family(env, PathOracle.for_env(env, subgoal_reach_m=2.0), episodes=1, seed=0)
    layout = env.unwrapped.layout
    assert env.max_steps == in_maze.step_limit(layout.walls, layout.start_cell, layout.goal_cell, 4.0)
    assert figures["mean_low_level_steps"] == env.max_steps
    assert (figures["successes"], figures["flips"], figures["frozen"], figures["timeouts"]) == (0, 0, 1, 0)
    assert figures["subgoals"] == len(env.paths)
    assert figures["success_ci95"][0] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="episodes must be >= 1, got 0"):
        in_maze.evaluate_family(env, PathOracle.for_env(env), episodes=0, seed=0)


def test_unknown_family_is_named():
    with pytest.raises(ValueError, match="unknown maze family 'open'"):
        in_maze.family_env("open", StillController())


def test_chunks_cover_every_seed_once_in_order():
    chunks = in_maze.chunks_of(7, 100, 3)
    assert [list(chunk) for chunk in chunks] == [[100, 101, 102], [103, 104, 105], [106]]


def test_parse_smoothing_names_the_bad_entry():
    assert in_maze.parse_smoothing("0,0.25") == [0.0, 0.25]
    with pytest.raises(ValueError, match="must lie in \\[0, 1\\), got 1"):
        in_maze.parse_smoothing("0,1")
    with pytest.raises(ValueError, match="'x' is not a number"):
        in_maze.parse_smoothing("0.2,x")


def test_chunked_episodes_merge_to_the_single_run(monkeypatch):
    # Chunks given in reverse order: the merge puts them back by seed, adding up to what one process gives.
    monkeypatch.setattr(in_maze, "load_low_level", lambda body, path: WalkController())
    monkeypatch.setattr(in_maze, "_MODELS", {})  # the stand-in must not stay cached for later tests
    whole = in_maze.run([None], ["u"], episodes=3, seed=5, jobs=1)
    parts = [in_maze.run_chunk(None, 0.0, "u", seeds, 2.0)[2] for seeds in reversed(in_maze.chunks_of(3, 5, 2))]
    merged = in_maze.summarise(in_maze.merge_raw(parts))
    single = whole["shipped"]["families"]["u"]
    timing_free = {key for key in single if key not in ("seconds", "success_ratio_to_first")}
    assert {key: merged[key] for key in timing_free} == {key: single[key] for key in timing_free}
    assert merged["maze_seed"] == 5 and merged["episodes"] == 3


class WalkController:
    """The same torques at every step (a picklable stand-in for a policy)."""

    def __call__(self, observation):
        return np.full(8, 0.7)


@pytest.mark.slow
def test_a_pool_of_workers_gives_the_figures_of_one_process():
    one = in_maze.run([None], ["ant3"], episodes=2, seed=0, smoothing=(0.0, 0.5), jobs=1)
    pool = in_maze.run([None], ["ant3"], episodes=2, seed=0, smoothing=(0.0, 0.5), jobs=2, chunk_episodes=1)
    assert list(pool) == ["shipped", "shipped smoothing=0.5"]
    for name in one:
        a, b = one[name]["families"]["ant3"], pool[name]["families"]["ant3"]
        assert {k: v for k, v in a.items() if k != "seconds"} == {k: v for k, v in b.items() if k != "seconds"}
    assert pool["shipped smoothing=0.5"]["action_smoothing"] == 0.5


def test_turn_degrees_measures_against_the_direction_of_travel():
    here = np.array([1.0, 0.0])
    walked_from = np.zeros(2)  # travelling along +x
    assert in_maze.turn_degrees(walked_from, here, np.array([3.0, 0.0])) == pytest.approx(0.0)
    assert in_maze.turn_degrees(walked_from, here, np.array([1.0, -2.0])) == pytest.approx(90.0)
    assert in_maze.turn_degrees(walked_from, here, np.array([-1.0, 0.1])) == pytest.approx(
        180 - np.degrees(np.arctan(0.05))
    )
    assert np.isnan(in_maze.turn_degrees(here, here + 0.1, np.array([5.0, 5.0])))  # 0.14 m: a standstill


def test_flip_diagnostics_bins_flips_by_turn_and_counts_early_ones():
    raw = {
        "turns": [10.0, 50.0, 180.0, 170.0, 100.0, float("nan")],
        "subgoal_flipped": [False, True, True, False, False, True],
        "flip_steps": [3, 40, 12],
    }
    figures = in_maze.flip_diagnostics(raw)
    assert figures["by_turn_degrees"]["0-45"] == {"subgoals": 1, "flips": 0, "flips_per_subgoal": 0.0}
    assert figures["by_turn_degrees"]["45-90"]["flips"] == 1
    assert figures["by_turn_degrees"]["135-180"] == {"subgoals": 2, "flips": 1, "flips_per_subgoal": 0.5}
    assert figures["by_turn_degrees"]["standstill"] == {"subgoals": 1, "flips": 1, "flips_per_subgoal": 1.0}
    assert figures["flip_steps_into_subgoal_median"] == 12.0
    assert figures[f"flips_within_{in_maze.EARLY_FLIP_STEPS}_steps_of_a_new_subgoal"] == 1
    assert in_maze.flip_diagnostics({"turns": [], "subgoal_flipped": [], "flip_steps": []})["by_turn_degrees"][
        "0-45"
    ] == {"subgoals": 0, "flips": 0, "flips_per_subgoal": None}


def test_the_recorder_keeps_one_turn_per_subgoal():
    env = in_maze.MazeEpisodeRecorder(
        gym.make("antmaze_hirl/AntMaze-v0", maze_map="u", low_level=StillController(), max_steps=60),
        scale_step_limit=False,
    )
    raw = in_maze.play_episodes(env, PathOracle.for_env(env, subgoal_reach_m=2.0), range(3, 4))
    assert len(raw["turns"]) == len(raw["subgoal_flipped"]) == raw["subgoals"] == len(env.paths)
    assert np.isnan(raw["turns"]).all()  # a still ant never travels: every subgoal is set at a standstill
    assert not any(raw["subgoal_flipped"])


def test_a_row_asked_for_twice_is_refused_before_any_episode():
    with pytest.raises(ValueError, match=r"rows \['shipped'\] are asked for twice"):
        in_maze.run([None], ["u"], episodes=1, seed=0, smoothing=(0.0, 0.0))
    with pytest.raises(ValueError, match=r"a\.zip smoothing=0\.5"):
        in_maze.row_names([Path("a.zip"), Path("a.zip")], (0.0, 0.5))


class SteerModel:
    """An SB3-style model (``predict``): torques from the goal offset and joint angles, row by row.

    Each env wraps a model in a controller of its own, so this checks that a chunk's mazes still share one;
    its batched rows equal its single ones bit for bit.
    """

    def predict(self, observation, deterministic=True):
        offset = observation["desired_goal"] - observation["achieved_goal"]
        joints = observation["observation"][..., 7:15]
        return np.tanh(np.concatenate([offset] * 4, axis=-1) - joints), None


def test_lockstep_plays_the_serial_episodes(monkeypatch):
    # More episodes than sub-envs, so a sub-env plays a second maze after its first ends (its paths restart).
    monkeypatch.setattr(in_maze, "load_low_level", lambda body, path: SteerModel())
    monkeypatch.setattr(in_maze, "_MODELS", {})
    serial = in_maze.run_chunk(None, 0.0, "u", range(5, 8), 2.0, num_envs=1)[2]
    lockstep = in_maze.run_chunk(None, 0.0, "u", range(5, 8), 2.0, num_envs=2)[2]
    assert len(serial["outcomes"]) == 3
    del serial["seconds"], lockstep["seconds"]
    np.testing.assert_equal(lockstep, serial)  # NaN turns (standstills) count as equal
