import hashlib
import pickle

import gymnasium as gym
import numpy as np
import pytest

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl.envs.layout_splits import layout_split, sample_layout_in_split, wall_grid_split
from antmaze_hirl.envs.layouts import MazeLayout, canonical_layout, generate_layout, wall_grid_string
from antmaze_hirl.envs.split_env import SplitMazeEnv
from antmaze_hirl.sb3_ext.shipped import ShippedPolicyController


def still(action_dim):
    return lambda obs: np.zeros(action_dim)


def family_sampler(body, maze_size):
    # The family exactly as the experiment draws it: the high-level env's own sampler.
    env = gym.make(
        f"antmaze_hirl/{body.capitalize()}Maze-v0", maze_size=maze_size, low_level=still(8 if body == "ant" else 2)
    )
    return env.unwrapped.sample_layout


def test_canonical_layout_marks_walls_start_and_goal():
    walls = np.ones((5, 5), dtype=bool)
    walls[1, 1:4] = walls[2, 1] = walls[2, 3] = walls[3, 1:4] = False
    layout = MazeLayout(walls, (1, 1), (3, 3))
    assert canonical_layout(layout) == "11111/1S001/10101/100G1/11111"
    assert layout.canonical() == canonical_layout(layout)
    assert wall_grid_string(walls) == "11111/10001/10101/10001/11111"


def test_split_is_the_documented_hash_of_the_wall_grid():
    rng = np.random.default_rng(3)
    for _ in range(50):
        layout = generate_layout(rng, n_rows=4, n_cols=4)
        bucket = int(hashlib.sha256(wall_grid_string(layout.walls).encode()).hexdigest(), 16) % 10
        expected = "eval" if bucket < 2 else "selection" if bucket == 2 else "train"
        assert layout_split(layout) == wall_grid_split(layout.walls) == expected
        # Start and goal do not move a layout to another part.
        moved = MazeLayout(layout.walls, layout.goal_cell, layout.start_cell)
        assert layout_split(moved) == expected


@pytest.mark.integration
@pytest.mark.parametrize(("body", "maze_size"), [("ant", 3), ("point", 5)])
def test_training_and_evaluation_mazes_share_no_wall_grid(body, maze_size):
    sample = family_sampler(body, maze_size)
    rng = np.random.default_rng(0)
    drawn = {split: [sample_layout_in_split(sample, rng, split) for _ in range(2000)] for split in ("train", "eval")}
    grids = {split: {wall_grid_string(layout.walls) for layout in layouts} for split, layouts in drawn.items()}
    assert grids["train"].isdisjoint(grids["eval"])
    assert all(layout_split(layout) == split for split, layouts in drawn.items() for layout in layouts)
    assert len(grids["eval"]) > 1  # rejection keeps the family's variety within the part


def test_sampling_a_part_the_family_lacks_is_a_clear_error():
    one_grid = MazeLayout(np.pad(np.zeros((2, 2), dtype=bool), 1, constant_values=True), (1, 1), (2, 2))
    missing = next(split for split in ("train", "eval", "selection") if split != layout_split(one_grid))
    with pytest.raises(ValueError, match=rf"no layout in split '{missing}' in 10 draws \(1 distinct wall grids"):
        sample_layout_in_split(lambda rng: one_grid, np.random.default_rng(0), missing, max_tries=10)
    with pytest.raises(ValueError, match="unknown layout split 'test'"):
        sample_layout_in_split(lambda rng: one_grid, np.random.default_rng(0), "test")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="max_tries must be >= 1, got 0"):
        sample_layout_in_split(lambda rng: one_grid, np.random.default_rng(0), "eval", max_tries=0)


def test_split_env_draws_every_layout_from_its_part():
    env = SplitMazeEnv("point", split="selection", maze_size=3, low_level=still(2))
    assert layout_split(env.layout) == "selection"  # the layout drawn at construction too
    for seed in range(5):
        env.reset(seed=seed)
        assert layout_split(env.layout) == "selection"
    # sample_task (reset and the trainer) draws through sample_layout: same rng state, same layout.
    first = env.unwrapped.sample_layout(np.random.default_rng(7))
    assert canonical_layout(first) == canonical_layout(env.unwrapped.sample_layout(np.random.default_rng(7)))
    assert layout_split(first) == "selection"
    env.close()
    with pytest.raises(ValueError, match="unknown layout split 'val'"):
        SplitMazeEnv("point", split="val", maze_size=3, low_level=still(2))  # type: ignore[arg-type]


def test_split_env_pickles_with_its_split():
    # the shipped low level's controller pickles as its body's name
    env = SplitMazeEnv("point", split="eval", maze_size=3, low_level=ShippedPolicyController("point"))
    copy = pickle.loads(pickle.dumps(env))
    assert copy.split == "eval" and layout_split(copy.layout) == "eval"
    env.close()
    copy.close()
