"""Bird's-eye images of a maze drawn from its wall grid with NumPy (cheap, no OpenGL)."""

from __future__ import annotations

import numpy as np

from antmaze_hirl.envs.geometry import MazeGeometry

WALL_CHANNEL, AGENT_CHANNEL, GOAL_CHANNEL = 0, 1, 2


class BirdseyeRenderer:
    """Draws ``(3, rows * ppc, cols * ppc)`` uint8 images: walls, agent and goal channels.

    Wall pixels are 255 in channel 0 over whole cells, so the wall grid is recovered exactly by
    ``image[0, ::ppc, ::ppc] > 127``. Agent and goal are filled squares in channels 1 and 2.

    Args:
        geometry: Map placement in the world.
        pixels_per_cell: Pixels per cell side.
        marker_radius: Half-width of the agent/goal squares, pixels. Default ``pixels_per_cell // 4``.

    """

    def __init__(self, geometry: MazeGeometry, pixels_per_cell: int = 8, marker_radius: int | None = None) -> None:
        if pixels_per_cell < 1:
            raise ValueError(f"pixels_per_cell must be >= 1, got {pixels_per_cell}")
        self.geometry = geometry
        self.pixels_per_cell = pixels_per_cell
        self.marker_radius = marker_radius if marker_radius is not None else pixels_per_cell // 4
        self.shape = (3, geometry.n_rows * pixels_per_cell, geometry.n_cols * pixels_per_cell)
        self._walls_key: bytes | None = None
        self._wall_pixels = np.zeros(self.shape[1:], dtype=np.uint8)

    def observation(self, walls: np.ndarray, agent_xy: np.ndarray, goal_xy: np.ndarray) -> np.ndarray:
        """The channel-first image for a policy."""
        image = np.zeros(self.shape, dtype=np.uint8)
        image[WALL_CHANNEL] = self._walls_image(walls)
        self._mark(image[AGENT_CHANNEL], agent_xy)
        self._mark(image[GOAL_CHANNEL], goal_xy)
        return image

    def rgb(self, walls: np.ndarray, agent_xy: np.ndarray, goal_xy: np.ndarray, upscale: int = 4) -> np.ndarray:
        """A ``(H, W, 3)`` picture for people: grey walls, blue agent, red goal, on white."""
        image = self.observation(walls, agent_xy, goal_xy)
        rgb = np.full((*self.shape[1:], 3), 255, dtype=np.uint8)
        rgb[image[WALL_CHANNEL] > 0] = (90, 90, 90)
        rgb[image[GOAL_CHANNEL] > 0] = (220, 40, 40)
        rgb[image[AGENT_CHANNEL] > 0] = (40, 80, 220)
        return np.kron(rgb, np.ones((upscale, upscale, 1), dtype=np.uint8))

    def walls_from_image(self, image: np.ndarray) -> np.ndarray:
        """Inverse of the wall channel: the boolean wall grid."""
        ppc = self.pixels_per_cell
        return np.asarray(image)[WALL_CHANNEL, ppc // 2 :: ppc, ppc // 2 :: ppc] > 127

    def _walls_image(self, walls: np.ndarray) -> np.ndarray:
        # Layouts change once per episode while images are drawn every step: cache the wall layer.
        key = np.packbits(walls).tobytes() + bytes(walls.shape)
        if key != self._walls_key:
            ppc = self.pixels_per_cell
            self._wall_pixels = np.kron(walls.astype(np.uint8) * 255, np.ones((ppc, ppc), dtype=np.uint8))
            self._walls_key = key
        return self._wall_pixels

    def _mark(self, channel: np.ndarray, xy: np.ndarray) -> None:
        row, col = self.geometry.xy_to_pixel(xy, self.pixels_per_cell)
        r = self.marker_radius
        channel[max(row - r, 0) : row + r + 1, max(col - r, 0) : col + r + 1] = 255
