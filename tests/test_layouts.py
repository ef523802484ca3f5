import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antmaze_hirl.envs.layouts import (
    STANDARD_MAPS,
    bfs_distances,
    corner_cells,
    generate_layout,
    layout_from_map,
    shortest_path,
    validate_maze_map,
)

SMALL = [
    [1, 1, 1, 1],
    [1, 0, 0, 1],
    [1, 1, 0, 1],
    [1, 1, 1, 1],
]


@pytest.mark.parametrize("name", sorted(STANDARD_MAPS))
def test_standard_maps_validate(name):
    walls = validate_maze_map(name)
    assert walls.shape == np.asarray(STANDARD_MAPS[name]).shape
    assert walls[0].all() and walls[-1].all() and walls[:, 0].all() and walls[:, -1].all()


@pytest.mark.parametrize(
    ("maze_map", "message"),
    [
        ([[1, 1, 1], [1, 0, 1, 1], [1, 1, 1]], r"not rectangular: row 1 has 4 cells"),
        ([[1, 1, 1], [1, "x", 1], [1, 1, 1]], r"unknown symbol 'x' at cell \(1, 1\)"),
        ([[1, 1, 1], [1, 2, 1], [1, 1, 1]], r"unknown symbol 2 at cell \(1, 1\)"),
        ([[1, 1, 1], [1, 0, 0], [1, 1, 1]], r"border must be all walls .* cell \(1, 2\) is free"),
        ([[1, 1, 1], [1, 1, 1], [1, 1, 1]], r"no free cell"),
        ([[1, 1, 1, 1, 1], [1, "r", 1, "g", 1], [1, 1, 1, 1, 1]], r"marked cell \(1, 3\) is not reachable"),
        ([[1, 1], [1, 1]], r"at least 3 rows"),
        ("labyrinth", r"unknown maze name 'labyrinth'"),
    ],
)
def test_validator_names_the_problem(maze_map, message):
    with pytest.raises(ValueError, match=message):
        validate_maze_map(maze_map)


def test_unreachable_goal_and_start_are_named():
    walls = np.array([[1, 1, 1, 1, 1], [1, 0, 1, 0, 1], [1, 1, 1, 1, 1]], dtype=bool)
    with pytest.raises(ValueError, match=r"goal cell \(1, 3\) is not reachable from start cell \(1, 1\)"):
        shortest_path(walls, (1, 1), (1, 3))
    with pytest.raises(ValueError, match=r"start cell \(0, 0\) is outside the maze or a wall"):
        shortest_path(walls, (0, 0), (1, 3))


def test_layout_from_map_rejects_impossible_goal_distance():
    with pytest.raises(ValueError, match="min_goal_cells=10"):
        layout_from_map(SMALL, np.random.default_rng(0), min_goal_cells=10)


def test_shortest_path_is_shortest_and_connected():
    walls = validate_maze_map("medium")
    path = shortest_path(walls, (1, 1), (6, 6))
    assert len(path) - 1 == bfs_distances(walls, (1, 1))[6, 6]
    for (r0, c0), (r1, c1) in itertools.pairwise(path):
        assert abs(r0 - r1) + abs(c0 - c1) == 1
        assert not walls[r1, c1]


def test_corner_cells_of_u_maze():
    assert corner_cells(validate_maze_map("u")) == [(1, 1), (1, 3), (3, 1), (3, 3)]


LAYOUT_DRAWS = {
    "seed": st.integers(0, 2**32 - 1),
    "n_rows": st.integers(2, 8),
    "n_cols": st.integers(2, 8),
    "wall_fraction": st.floats(0.0, 0.6),
}


@settings(max_examples=300, deadline=None)
@given(**LAYOUT_DRAWS)
def test_generated_layouts_are_connected_with_reachable_start_and_goal(seed, n_rows, n_cols, wall_fraction):
    check_generated_layout(seed, n_rows, n_cols, wall_fraction)


@pytest.mark.slow  # the same property on 2,000 draws (about 10 s); the unit tier's test above draws 300
@settings(max_examples=2000, deadline=None)
@given(**LAYOUT_DRAWS)
def test_generated_layouts_are_connected_with_reachable_start_and_goal_on_many_draws(
    seed, n_rows, n_cols, wall_fraction
):
    check_generated_layout(seed, n_rows, n_cols, wall_fraction)


def check_generated_layout(seed, n_rows, n_cols, wall_fraction):
    """The layout of these draws is connected, its start in a corner and its goal reachable and apart."""
    layout = generate_layout(
        np.random.default_rng(seed), n_rows=n_rows, n_cols=n_cols, wall_fraction=wall_fraction, min_goal_cells=1
    )
    walls = layout.walls
    assert walls.shape == (n_rows + 2, n_cols + 2)
    np.testing.assert_array_equal(validate_maze_map(layout.to_maze_map()), walls)
    distances = bfs_distances(walls, layout.start_cell)
    assert (distances[~walls] >= 0).all(), "every free cell is connected"
    assert not walls[layout.start_cell] and not walls[layout.goal_cell]
    assert distances[layout.goal_cell] >= 1
    assert layout.start_cell in corner_cells(walls)


def test_generator_is_seeded_and_respects_goal_distance():
    first = generate_layout(np.random.default_rng(7), min_goal_cells=5)
    again = generate_layout(np.random.default_rng(7), min_goal_cells=5)
    other = generate_layout(np.random.default_rng(8), min_goal_cells=5)
    np.testing.assert_array_equal(first.walls, again.walls)
    assert (first.start_cell, first.goal_cell) == (again.start_cell, again.goal_cell)
    assert not np.array_equal(first.walls, other.walls)
    assert bfs_distances(first.walls, first.start_cell)[first.goal_cell] >= 5
    assert abs(first.walls[1:-1, 1:-1].mean() - 0.3) < 0.05


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_rows": 0}, "at least 1x1"),
        ({"wall_fraction": 1.0}, r"wall_fraction must lie in \[0, 1\)"),
        ({"n_rows": 2, "n_cols": 2, "min_goal_cells": 9}, "min_goal_cells=9"),
    ],
)
def test_generator_rejects_bad_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        generate_layout(np.random.default_rng(0), **kwargs)


def test_segment_clearance_is_exact_at_wall_corners():
    from antmaze_hirl.envs.geometry import MazeGeometry

    walls = validate_maze_map("u")  # cell (2, 1) and (2, 2) are walls: square x in [-1.5, 0.5], y in [-0.5, 0.5]
    geometry = MazeGeometry(*walls.shape, scale=1.0)
    along = np.array([0.5 + 0.3, 0.9]), np.array([0.5 + 0.3, -0.9])  # vertical line 0.3 m right of the block
    assert geometry.segment_is_free(walls, *along, clearance_m=0.29)
    assert not geometry.segment_is_free(walls, *along, clearance_m=0.31)
    diagonal = np.array([1.0, 0.2]), np.array([0.0, -1.0])  # free ends, but cuts the block's corner (0.5, -0.5)
    assert not geometry.segment_is_free(walls, *diagonal)
    assert not geometry.segment_is_free(walls, np.array([1.0, 1.0]), np.array([1.0, 5.0]))  # ends outside
