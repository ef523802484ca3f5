"""Observation encoding for the high-level policy: an agent-centred maze grid plus planar vectors.

Layouts change every episode, so the policy must generalise across mazes. The encoding is made
translation invariant by centring the maze grid on the agent's cell (a ``(2R-1) x (2R-1)`` window,
``R`` the larger map side, so the whole maze is always in view), and the eight symmetries of the
square (:func:`augment`) multiply the few expert labels a DAgger run collects.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.state_layout import STATE_LAYOUT

GRID_CHANNELS = 2  # walls, goal
OFFSET_FEATURE_DIM = 4  # goal offset (x, y) and agent offset within its cell (x, y), both in cells
BODY_CLIP = 10.0


@dataclass(frozen=True)
class EncodedBatch:
    """Encoded observations: ``grids (B, 2, S, S)`` float32 and ``vectors (B, 4 + body_dim)`` float32."""

    grids: np.ndarray
    vectors: np.ndarray

    def __post_init__(self) -> None:
        if self.grids.ndim != 4 or self.vectors.ndim != 2 or len(self.grids) != len(self.vectors):
            raise ValueError(f"mismatched encoded batch: grids {self.grids.shape}, vectors {self.vectors.shape}")

    def __len__(self) -> int:
        return len(self.grids)


class ObservationEncoder:
    """Turns high-level observations (or their parts) into policy inputs.

    Args:
        geometry: Map placement of the env.
        pixels_per_cell: The env's image resolution (to read walls back from the image).
    """

    def __init__(self, geometry: MazeGeometry, pixels_per_cell: int) -> None:
        self.geometry = geometry
        self.renderer = BirdseyeRenderer(geometry, pixels_per_cell)
        self.radius = max(geometry.n_rows, geometry.n_cols)
        self.grid_size = 2 * self.radius - 1

    def encode_observations(self, observations: list[dict[str, np.ndarray]]) -> EncodedBatch:
        """Encodes a list of high-level observation dicts."""
        parts = [
            (
                self.renderer.walls_from_image(obs["image"]),
                np.asarray(STATE_LAYOUT.agent_xy(obs["state"]), dtype=np.float64),
                np.asarray(STATE_LAYOUT.goal_xy(obs["state"]), dtype=np.float64),
                np.asarray(STATE_LAYOUT.body_observation(obs["state"]), dtype=np.float64),
            )
            for obs in observations
        ]
        return self.encode(*map(list, zip(*parts, strict=True)))

    def encode(
        self, walls: list[np.ndarray], agent_xy: list[np.ndarray], goal_xy: list[np.ndarray], body: list[np.ndarray]
    ) -> EncodedBatch:
        """Encodes parallel lists of wall grids, agent xy, goal xy and body observations."""
        grids = np.stack([self._grid(w, a, g) for w, a, g in zip(walls, agent_xy, goal_xy, strict=True)])
        vectors = np.stack([self._vector(a, g, b) for a, g, b in zip(agent_xy, goal_xy, body, strict=True)])
        return EncodedBatch(grids.astype(np.float32), vectors.astype(np.float32))

    def _grid(self, walls: np.ndarray, agent_xy: np.ndarray, goal_xy: np.ndarray) -> np.ndarray:
        grid = np.zeros((GRID_CHANNELS, self.grid_size, self.grid_size), dtype=np.float32)
        grid[0] = 1.0  # outside the map counts as wall
        row, col = self.geometry.xy_to_cell(agent_xy)
        row, col = int(np.clip(row, 0, walls.shape[0] - 1)), int(np.clip(col, 0, walls.shape[1] - 1))
        top, left = self.radius - 1 - row, self.radius - 1 - col
        grid[0, top : top + walls.shape[0], left : left + walls.shape[1]] = walls
        goal_row, goal_col = self.geometry.xy_to_cell(goal_xy)
        if 0 <= goal_row < walls.shape[0] and 0 <= goal_col < walls.shape[1]:
            grid[1, top + goal_row, left + goal_col] = 1.0
        return grid

    def _vector(self, agent_xy: np.ndarray, goal_xy: np.ndarray, body: np.ndarray) -> np.ndarray:
        scale = self.geometry.scale
        cell_centre = self.geometry.cell_to_xy(self.geometry.xy_to_cell(agent_xy))
        planar = np.concatenate([(goal_xy - agent_xy) / scale, (agent_xy - cell_centre) / scale])
        return np.concatenate([planar, np.clip(body, -BODY_CLIP, BODY_CLIP) / BODY_CLIP])


# Each symmetry of the square: (rotations by 90 degrees counter-clockwise, mirror x first?).
SYMMETRIES: tuple[tuple[int, bool], ...] = tuple((k, flip) for flip in (False, True) for k in range(4))


def transform_planar(vectors: np.ndarray, k: int, flip: bool) -> np.ndarray:
    """Applies symmetry ``(k, flip)`` to world-frame xy vectors in the last axis (pairs of columns)."""
    out = np.array(vectors, dtype=np.float32, copy=True)
    x, y = out[..., 0::2].copy(), out[..., 1::2].copy()
    if flip:
        x = -x
    for _ in range(k):
        x, y = -y, x
    out[..., 0::2], out[..., 1::2] = x, y
    return out


def transform_grids(grids: np.ndarray, k: int, flip: bool) -> np.ndarray:
    """Applies symmetry ``(k, flip)`` to ``(..., S, S)`` grids drawn with row 0 at the top (+y)."""
    out = np.flip(grids, axis=-1) if flip else grids
    return np.ascontiguousarray(np.rot90(out, k=k, axes=(-2, -1)))


def augment(
    batch: EncodedBatch, labels: np.ndarray, rng: np.random.Generator, *, planar_feature_dim: int = OFFSET_FEATURE_DIM
) -> tuple[EncodedBatch, np.ndarray]:
    """Applies one random symmetry per sample to grids, the first ``planar_feature_dim`` features and labels.

    ``planar_feature_dim`` counts the world-frame xy pairs at the start of the feature vector: the goal offset
    and in-cell offset, plus the body's velocity for the point mass (its whole body state). The ant's
    body state (torso orientation, joint state) has no planar form and stays as it is: an approximation
    that only matters in so far as the subgoal depends on which way the torso faces.

    Sample ``i`` gets ``SYMMETRIES[c_i]`` for ``c = rng.integers(8, size=len(batch))``, exactly as
    :func:`transform_grids` and :func:`transform_planar` would apply it.
    """
    # One gather for the whole batch instead of a masked rot90 per symmetry: it runs before each of the
    # learner's gradient steps (200 an episode), where the per-symmetry loop cost about 5% of a step. The
    # values are only moved and negated, never computed, so the batch is the same bit for bit
    # (tests/test_dagger.py checks it against the per-symmetry loop).
    grids, vectors, labels = batch.grids, batch.vectors.copy(), np.array(labels, dtype=np.float32)
    choices = rng.integers(len(SYMMETRIES), size=len(batch))
    pixels = _pixel_orders(grids.shape[-1])[choices]  # (B, S * S): where each new pixel comes from
    flat = grids.reshape(len(grids), grids.shape[1], -1)
    turned = np.take_along_axis(flat, pixels[:, None, :], axis=2).reshape(grids.shape)
    vectors[:, :planar_feature_dim] = _turn_pairs(vectors[:, :planar_feature_dim], choices)
    return EncodedBatch(turned, vectors), _turn_pairs(labels, choices)


def _pixel_orders(side: int) -> np.ndarray:
    # Row s: the flat source index of each pixel of transform_grids(grid, *SYMMETRIES[s]) on a side x side grid.
    if side not in _PIXEL_ORDERS:
        index = np.arange(side * side).reshape(side, side)
        _PIXEL_ORDERS[side] = np.stack([transform_grids(index, k, flip).reshape(-1) for k, flip in SYMMETRIES])
    return _PIXEL_ORDERS[side]


_PIXEL_ORDERS: dict[int, np.ndarray] = {}


def _turn_pairs(values: np.ndarray, choices: np.ndarray) -> np.ndarray:
    # transform_planar with symmetry SYMMETRIES[choices[i]] on row i: each symmetry moves x and y to x' = +-x or
    # +-y and y' = the other, so a swap and two negations per row, in float32 as transform_planar computes.
    out = np.array(values, dtype=np.float32, copy=True)
    x, y = out[:, 0::2], out[:, 1::2]
    swap, negate_x, negate_y = (table[choices][:, None] for table in _PLANAR_MOVES)
    new_x, new_y = np.where(swap, y, x), np.where(swap, x, y)
    out[:, 0::2] = np.where(negate_x, -new_x, new_x)
    out[:, 1::2] = np.where(negate_y, -new_y, new_y)
    return out


def _planar_moves() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # Per symmetry: whether x and y swap, and whether the new x and new y are negated (read off transform_planar).
    probe = np.array([[1.0, 2.0]], dtype=np.float32)
    moved = np.stack([transform_planar(probe, k, flip)[0] for k, flip in SYMMETRIES])
    return np.abs(moved[:, 0]) == 2.0, moved[:, 0] < 0, moved[:, 1] < 0


_PLANAR_MOVES = _planar_moves()
