"""Conversion between maze cells, world xy (metres) and bird's-eye image pixels."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from antmaze_hirl.envs.layouts import Cell


@dataclass(frozen=True)
class MazeGeometry:
    """Placement of a ``n_rows x n_cols`` map in the world, as gymnasium-robotics lays it out.

    The map is centred on the origin; ``x`` grows with the column and ``y`` shrinks with the row.

    Attributes:
        n_rows: Map rows, border included.
        n_cols: Map columns, border included.
        scale: Cell side in metres (4 for the ant, 1 for the point mass).

    """

    n_rows: int
    n_cols: int
    scale: float

    @property
    def low(self) -> np.ndarray:
        """Lowest ``(x, y)`` inside the outer border of the map."""
        return np.array([-self.n_cols / 2 * self.scale, -self.n_rows / 2 * self.scale])

    @property
    def high(self) -> np.ndarray:
        """Highest ``(x, y)`` inside the outer border of the map."""
        return -self.low

    def cell_to_xy(self, cell: Cell | np.ndarray) -> np.ndarray:
        """Centre of cell ``(row, col)`` in world metres."""
        row, col = cell[0], cell[1]
        return np.array([(col + 0.5) * self.scale, -(row + 0.5) * self.scale]) + np.array([self.low[0], self.high[1]])

    def xy_to_cell(self, xy: np.ndarray) -> Cell:
        """Cell ``(row, col)`` that contains world point ``xy`` (may lie outside the map)."""
        col = int(np.floor((xy[0] - self.low[0]) / self.scale))
        row = int(np.floor((self.high[1] - xy[1]) / self.scale))
        return row, col

    def xy_to_pixel(self, xy: np.ndarray, pixels_per_cell: int) -> tuple[int, int]:
        """Pixel ``(row, col)`` of ``xy`` in an image with ``pixels_per_cell`` pixels per cell side."""
        col = (xy[0] - self.low[0]) / self.scale * pixels_per_cell
        row = (self.high[1] - xy[1]) / self.scale * pixels_per_cell
        return int(np.clip(row, 0, self.n_rows * pixels_per_cell - 1)), int(
            np.clip(col, 0, self.n_cols * pixels_per_cell - 1)
        )

    def is_free(self, walls: np.ndarray, xy: np.ndarray) -> bool:
        """Whether ``xy`` lies in a free cell of ``walls``."""
        row, col = self.xy_to_cell(xy)
        return 0 <= row < self.n_rows and 0 <= col < self.n_cols and not walls[row, col]

    def segment_is_free(self, walls: np.ndarray, start: np.ndarray, end: np.ndarray, clearance_m: float = 0.0) -> bool:
        """Whether the straight segment ``start -> end`` keeps more than ``clearance_m`` from every wall.

        Exact (no sampling): the distance from the segment to each nearby wall square is computed.

        Args:
            walls: Boolean wall grid.
            start: Segment start, world metres.
            end: Segment end, world metres.
            clearance_m: Required gap, so a body of that half-width does not clip a wall corner.
        """
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        if not (self.is_free(walls, start) and self.is_free(walls, end)):
            return False
        margin = max(clearance_m, 1e-9)
        row_a, col_a = self.xy_to_cell(np.minimum(start, end) - margin)
        row_b, col_b = self.xy_to_cell(np.maximum(start, end) + margin)
        rows = range(max(min(row_a, row_b), 0), min(max(row_a, row_b), self.n_rows - 1) + 1)
        cols = range(max(min(col_a, col_b), 0), min(max(col_a, col_b), self.n_cols - 1) + 1)
        for row in rows:
            for col in cols:
                if walls[row, col]:
                    centre = self.cell_to_xy((row, col))
                    half = self.scale / 2
                    if _segment_box_distance(start, end, centre - half, centre + half) < margin:
                        return False
        return True


def _segment_box_distance(start: np.ndarray, end: np.ndarray, low: np.ndarray, high: np.ndarray) -> float:
    """Euclidean distance between a segment and an axis-aligned box (0 if they touch)."""
    if _segment_hits_box(start, end, low, high):
        return 0.0
    # Disjoint convex sets in 2D: the closest pair involves a segment endpoint or a box corner.
    candidates = [float(np.linalg.norm(np.maximum(np.maximum(low - p, 0.0), p - high))) for p in (start, end)]
    direction = end - start
    length_sq = float(direction @ direction)
    for corner in ((low[0], low[1]), (low[0], high[1]), (high[0], low[1]), (high[0], high[1])):
        corner = np.asarray(corner)
        t = 0.0 if length_sq == 0 else float(np.clip((corner - start) @ direction / length_sq, 0.0, 1.0))
        candidates.append(float(np.linalg.norm(start + t * direction - corner)))
    return min(candidates)


def _segment_hits_box(start: np.ndarray, end: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
    # Liang-Barsky clipping of the segment's parameter range against the box slabs.
    t_min, t_max = 0.0, 1.0
    direction = end - start
    for axis in range(2):
        if abs(direction[axis]) < 1e-12:
            if not low[axis] <= start[axis] <= high[axis]:
                return False
            continue
        t_a = (low[axis] - start[axis]) / direction[axis]
        t_b = (high[axis] - start[axis]) / direction[axis]
        t_min, t_max = max(t_min, min(t_a, t_b)), min(t_max, max(t_a, t_b))
        if t_min > t_max:
            return False
    return True
