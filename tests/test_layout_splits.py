import hashlib
import pickle

import gymnasium as gym
import numpy as np
import pytest

import antmaze_hirl  # noqa: F401  (registers the env ids)
from antmaze_hirl.dagger.features import SYMMETRIES, ObservationEncoder, augment, transform_grids
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layout_splits import layout_split, sample_layout_in_split, wall_grid_split, wall_grid_split_v1
from antmaze_hirl.envs.layouts import (
    SQUARE_SYMMETRIES,
    MazeLayout,
    canonical_layout,
    canonical_task,
    canonical_wall_grid,
    generate_layout,
    transform_layout,
    wall_grid_string,
)
from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.envs.split_env import SplitMazeEnv
from antmaze_hirl.sb3_ext.shipped import ShippedPolicyController


def still(action_dim):
    return lambda obs: np.zeros(action_dim)


def family_sampler(body, maze_size):
    # The family exactly as the experiment draws it: the high-level env's own sampler.
    env = gym.make(maze_env_id(body), maze_size=maze_size, low_level=still(8 if body == "ant" else 2))
    return env.unwrapped.sample_layout


def test_canonical_layout_marks_walls_start_and_goal():
    walls = np.ones((5, 5), dtype=bool)
    walls[1, 1:4] = walls[2, 1] = walls[2, 3] = walls[3, 1:4] = False
    layout = MazeLayout(walls, (1, 1), (3, 3))
    assert canonical_layout(layout) == "11111/1S001/10101/100G1/11111"
    assert layout.canonical() == canonical_layout(layout)
    assert wall_grid_string(walls) == "11111/10001/10101/10001/11111"


def test_split_is_the_documented_hash_of_the_canonical_wall_grid():
    rng = np.random.default_rng(3)
    for _ in range(50):
        layout = generate_layout(rng, n_rows=4, n_cols=4)
        images = [np.rot90(np.flip(layout.walls, 1) if flip else layout.walls, k) for flip in (0, 1) for k in range(4)]
        smallest = min(wall_grid_string(image) for image in images)
        assert canonical_wall_grid(layout.walls) == smallest
        bucket = int(hashlib.sha256(smallest.encode()).hexdigest(), 16) % 10
        expected = "eval" if bucket < 2 else "selection" if bucket == 2 else "train"
        assert layout_split(layout) == wall_grid_split(layout.walls) == expected
        assert {wall_grid_split(image) for image in images} == {expected}
        # Start and goal do not move a layout to another part.
        moved = MazeLayout(layout.walls, layout.goal_cell, layout.start_cell)
        assert layout_split(moved) == expected


def test_the_old_raw_hash_split_symmetric_images_the_new_one_does_not():
    # Protocol 1 (the committed held-out results) hashed the raw grid: its rotations fell in other parts.
    rng = np.random.default_rng(0)
    split_apart = 0
    for _ in range(100):
        walls = generate_layout(rng, n_rows=4, n_cols=4).walls
        images = [np.rot90(walls, k) for k in range(4)]
        split_apart += len({wall_grid_split_v1(image) for image in images}) > 1
        assert len({wall_grid_split(image) for image in images}) == 1
    assert split_apart > 20


def encoder_for(walls):
    n_rows, n_cols = walls.shape
    return ObservationEncoder(MazeGeometry(n_rows, n_cols, 1.0), pixels_per_cell=4)


def encoded_task_grids(layout):
    encoder = encoder_for(layout.walls)
    geometry = encoder.geometry
    body = np.zeros(2)
    return encoder.encode(
        [layout.walls], [geometry.cell_to_xy(layout.start_cell)], [geometry.cell_to_xy(layout.goal_cell)], [body]
    )


def test_the_partition_group_contains_the_learners_augmentation_group():
    # The learner's own code: each of its symmetries maps a wall grid to one of the partition's images,
    # in the same part, and its augmentation of an encoded task is the encoding of one of the task's images.
    rng = np.random.default_rng(1)
    for _ in range(20):
        layout = generate_layout(rng, n_rows=5, n_cols=5)
        images = {wall_grid_string(transform_layout(layout, k, flip).walls) for k, flip in SQUARE_SYMMETRIES}
        for k, flip in SYMMETRIES:
            learners_image = transform_grids(layout.walls, k, flip)
            assert wall_grid_string(learners_image) in images
            assert wall_grid_split(learners_image) == layout_split(layout)
            assert canonical_wall_grid(learners_image) == canonical_wall_grid(layout.walls)
        single = encoded_task_grids(layout)
        batch = type(single)(np.repeat(single.grids, 400, axis=0), np.repeat(single.vectors, 400, axis=0))
        augmented, _ = augment(batch, np.zeros((400, 2)), np.random.default_rng(2))
        images = [transform_layout(layout, k, flip) for k, flip in SQUARE_SYMMETRIES]
        ours = {encoded_task_grids(image).grids[0].tobytes() for image in images}
        theirs = {grid.tobytes() for grid in augmented.grids}
        assert theirs <= ours  # every augmented sample is an image the partition keeps in the same part
        assert len(theirs) == len(ours)  # and it reaches every distinct image (400 draws of 8)
        assert {canonical_task(transform_layout(layout, k, flip)) for k, flip in SQUARE_SYMMETRIES} == {
            canonical_task(layout)
        }


@pytest.fixture(scope="module", params=[("ant", 4), ("point", 5)], ids=["ant4", "point5"])
def drawn_parts(request):
    body, maze_size = request.param
    sample = family_sampler(body, maze_size)
    rng = np.random.default_rng(0)
    return {split: [sample_layout_in_split(sample, rng, split) for _ in range(2000)] for split in SPLITS}


SPLITS = ("train", "eval", "selection")


def learner_images(layout):
    """The task's eight images through the learner's own transform (dagger.features.transform_grids)."""
    shape = layout.walls.shape
    marks = np.zeros((2, *shape), dtype=bool)
    marks[(0, *layout.start_cell)] = marks[(1, *layout.goal_cell)] = True
    for k, flip in SYMMETRIES:
        walls, (start, goal) = transform_grids(layout.walls, k, flip), transform_grids(marks, k, flip)
        cells = [tuple(int(i) for i in np.argwhere(mark)[0]) for mark in (start, goal)]
        yield walls, MazeLayout(walls, *cells)


@pytest.mark.integration  # 2,000 draws per part and family
def test_parts_are_disjoint_under_every_symmetry(drawn_parts):
    grids = {split: {wall_grid_string(layout.walls) for layout in layouts} for split, layouts in drawn_parts.items()}
    tasks = {split: {canonical_layout(layout) for layout in layouts} for split, layouts in drawn_parts.items()}
    for split, layouts in drawn_parts.items():
        assert all(layout_split(layout) == split for layout in layouts)
        assert len(grids[split]) > 1  # rejection keeps the family's variety within the part
        others = [other for other in SPLITS if other != split]
        for layout in layouts:
            for walls, image in learner_images(layout):
                for other in others:
                    assert wall_grid_string(walls) not in grids[other], (split, other, wall_grid_string(walls))
                    assert canonical_layout(image) not in tasks[other], (split, other, canonical_layout(image))


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
    env = SplitMazeEnv("point", split="selection", maze_size=4, low_level=still(2))
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
        SplitMazeEnv("point", split="val", maze_size=4, low_level=still(2))  # type: ignore[arg-type]


def test_split_env_pickles_with_its_split():
    # the shipped low level's controller pickles as its body's name
    env = SplitMazeEnv("point", split="eval", maze_size=4, low_level=ShippedPolicyController("point"))
    copy = pickle.loads(pickle.dumps(env))
    assert copy.split == "eval" and layout_split(copy.layout) == "eval"
    env.close()
    copy.close()
