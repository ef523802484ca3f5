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

    def segment_is_free(self, walls: np.ndarray, start: np.ndarray, end: np.ndarray, clearance: float = 0.0) -> bool:
        """Whether the straight segment ``start -> end`` stays in free cells.

        Args:
            walls: Boolean wall grid.
            start: Segment start, world metres.
            end: Segment end, world metres.
            clearance: Also require the two parallel segments this many metres to either side to be free,
                so a body of that half-width does not clip a wall corner.

        """
        direction = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
        length = float(np.linalg.norm(direction))
        n_samples = max(2, int(np.ceil(length / (0.1 * self.scale))) + 1)
        normal = np.array([-direction[1], direction[0]]) / length if length > 0 else np.zeros(2)
        offsets = [0.0] if clearance <= 0 or length == 0 else [-clearance, 0.0, clearance]
        for t in np.linspace(0.0, 1.0, n_samples):
            point = start + t * direction
            if not all(self.is_free(walls, point + offset * normal) for offset in offsets):
                return False
        return True
