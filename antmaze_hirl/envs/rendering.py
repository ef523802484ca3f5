"""What a high-level maze env's ``render()`` draws: the 2D schematic, the schematic with the walk, or a MuJoCo camera.

The ``render_view`` keyword is documented with :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv`;
this module holds the drawing and the frame bookkeeping, so the env only tells it when an episode starts
and when the body has taken a low-level step.

Views (``render_view``):

* ``"schematic"`` (the default): the bird's-eye picture the env always drew (grey walls, blue body, red
  goal), NumPy only.
* ``"trail"``: the same picture plus the body's path since the episode began (a dark blue line) and the
  current subgoal (a green ring).
* ``"mujoco"``: a MuJoCo camera looking down on the whole maze at 60 degrees, rendered offscreen with the
  OpenGL backend that ``MUJOCO_GL`` names (``egl`` on a headless machine, as the study page's camera), with the
  path as small blue spheres, the current subgoal as MuJoCo's red target and the goal as a gold disc.

Render modes: ``"rgb_array"`` returns the current frame; ``"rgb_array_list"`` (Gymnasium's name for "every
frame since the last ``render()``") returns the frames drawn at the reset and after every low-level step,
so a high-level episode of ``n`` low-level steps gives ``n + 1`` frames.
"""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from antmaze_hirl.envs.birdseye import BirdseyeRenderer
from antmaze_hirl.envs.geometry import MazeGeometry

RENDER_VIEWS = ("schematic", "trail", "mujoco")
RENDER_MODES = ("rgb_array", "rgb_array_list")
SCHEMATIC_UPSCALE = 4
"""Screen pixels per image pixel of the schematic views (:meth:`BirdseyeRenderer.rgb`'s default)."""
MUJOCO_FRAME_PX = (480, 480)
"""Height and width of a MuJoCo frame (divisible by 16, as video encoders like)."""
MAX_TRAIL_MARKERS = 300
"""The MuJoCo view draws at most this many path points (evenly spaced); the scene's geometry buffer is finite."""

TRAIL_RGB = (20, 30, 120)
SUBGOAL_RGB = (30, 160, 60)


class RenderUnavailable(RuntimeError):
    """The MuJoCo view cannot render here (no OpenGL backend); the schematic views always can."""


def check_render_settings(render_mode: str | None, render_view: str) -> None:
    """Refuses an unknown render mode or view, and the MuJoCo view where no OpenGL backend is named.

    Raises:
        ValueError: Naming the value and the choices.
        RenderUnavailable: For ``render_view="mujoco"`` with neither ``MUJOCO_GL`` nor a display set.
    """
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode must be None, 'rgb_array' or 'rgb_array_list', got {render_mode!r}")
    if render_view not in RENDER_VIEWS:
        raise ValueError(f"render_view must be one of {list(RENDER_VIEWS)}, got {render_view!r}")
    if render_view == "mujoco" and not (os.environ.get("MUJOCO_GL") or os.environ.get("DISPLAY")):
        # Without either MuJoCo tries a windowed (GLFW) context, which a headless machine lacks; the backend is
        # read when mujoco is first imported, so it must be set before the process imports antmaze_hirl.
        raise RenderUnavailable(
            "render_view='mujoco' needs OpenGL: set MUJOCO_GL=egl (or osmesa) in the environment before Python starts"
        )


def draw_trail_schematic(
    birdseye: BirdseyeRenderer,
    walls: np.ndarray,
    path_xy: np.ndarray,
    goal_xy: np.ndarray,
    subgoal_xy: np.ndarray | None,
) -> np.ndarray:
    """The schematic ``(H, W, 3)`` picture with the path ``path_xy`` (last row: the body now) and a subgoal ring."""
    rgb = birdseye.rgb(walls, path_xy[-1], goal_xy, upscale=SCHEMATIC_UPSCALE)
    ppc = birdseye.pixels_per_cell * SCHEMATIC_UPSCALE
    geometry = birdseye.geometry
    pixels = np.array([geometry.xy_to_pixel(xy, ppc) for xy in path_xy])
    for start, end in itertools.pairwise(pixels):
        count = int(np.abs(end - start).max()) + 1
        rows = np.linspace(start[0], end[0], count).round().astype(int)
        cols = np.linspace(start[1], end[1], count).round().astype(int)
        rgb[rows, cols] = TRAIL_RGB
    if subgoal_xy is not None:
        row, col = geometry.xy_to_pixel(subgoal_xy, ppc)
        radius = max(ppc // 4, 2)
        grid_rows, grid_cols = np.ogrid[: rgb.shape[0], : rgb.shape[1]]
        distance = np.hypot(grid_rows - row, grid_cols - col)
        rgb[(distance <= radius) & (distance >= radius - 2)] = SUBGOAL_RGB
    return rgb


class MujocoView:
    """A MuJoCo overview camera of a maze simulation, rendered offscreen into ``(H, W, 3)`` uint8 arrays.

    The renderer is made on the first frame and remade when the simulation's model changes (a new layout
    rebuilds the model).

    Args:
        geometry: The maze's placement, to aim the camera at its centre and fit it in the frame.
        height_px: Frame height.
        width_px: Frame width.
    """

    def __init__(self, geometry: MazeGeometry, height_px: int = MUJOCO_FRAME_PX[0], width_px: int = MUJOCO_FRAME_PX[1]):
        self.geometry = geometry
        self.height_px, self.width_px = height_px, width_px
        self._renderer: Any = None
        self._model: Any = None

    def frame(self, data: Any, path_xy: np.ndarray, goal_xy: np.ndarray) -> np.ndarray:
        """The view of ``data`` (a ``mujoco.MjData``) with the path and the goal marked.

        Raises:
            RenderUnavailable: If OpenGL rendering fails here.
        """
        import mujoco

        try:
            if self._renderer is None or self._model is not data.model:
                self.close()
                self._renderer = mujoco.Renderer(data.model, self.height_px, self.width_px)
                self._model = data.model
            self._renderer.update_scene(data, camera=self._camera(mujoco))
            self._mark(mujoco, self._renderer.scene, path_xy, goal_xy)
            return np.asarray(self._renderer.render(), dtype=np.uint8)
        except RenderUnavailable:
            raise
        except Exception as error:  # any GL failure means: no MuJoCo view here
            raise RenderUnavailable(
                f"MuJoCo could not render here (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): {error}"
            ) from error

    def _camera(self, mujoco: Any) -> Any:
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.lookat[:] = (0.0, 0.0, 0.0)  # gymnasium-robotics centres the maze on the origin
        extent_m = float(np.max(self.geometry.high - self.geometry.low))
        camera.distance = 1.05 * extent_m / (2 * np.tan(np.radians(45.0 / 2)))  # MuJoCo's default fovy is 45
        camera.elevation, camera.azimuth = -60.0, 90.0
        return camera

    def _mark(self, mujoco: Any, scene: Any, path_xy: np.ndarray, goal_xy: np.ndarray) -> None:
        scale = self.geometry.scale
        markers = path_xy[np.linspace(0, len(path_xy) - 1, min(len(path_xy), MAX_TRAIL_MARKERS)).astype(int)]
        shapes = [
            (mujoco.mjtGeom.mjGEOM_SPHERE, (0.04 * scale,) * 3, (*xy, 0.05 * scale), (0.1, 0.2, 0.8, 0.8))
            for xy in markers
        ]
        shapes.append(
            (
                mujoco.mjtGeom.mjGEOM_CYLINDER,
                (0.15 * scale, 0.15 * scale, 0.01 * scale),
                (*goal_xy, 0.01),
                (1.0, 0.8, 0.1, 1.0),
            )
        )
        identity = np.eye(3).ravel()
        for kind, size, position, rgba in shapes:
            if scene.ngeom >= scene.maxgeom:
                return
            mujoco.mjv_initGeom(
                scene.geoms[scene.ngeom],
                kind,
                np.asarray(size),
                np.asarray(position, dtype=np.float64),
                identity,
                np.asarray(rgba, dtype=np.float32),
            )
            scene.ngeom += 1

    def close(self) -> None:
        """Frees the OpenGL context."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
            self._model = None


@dataclass
class EpisodeFrames:
    """The render state of one high-level env: its view, the episode's path so far and the frames not yet taken.

    Args:
        render_mode: ``None``, ``"rgb_array"`` or ``"rgb_array_list"``.
        render_view: One of :data:`RENDER_VIEWS`.
        birdseye: The env's schematic renderer.
    """

    render_mode: str | None
    render_view: str
    birdseye: BirdseyeRenderer
    path_xy: list[np.ndarray] = field(default_factory=list)
    subgoal_xy: np.ndarray | None = None
    pending: list[np.ndarray] = field(default_factory=list)
    mujoco_view: MujocoView | None = None

    def start_episode(self, env: Any) -> None:
        """Called at the end of a reset: a new path, and (list mode) the first frame."""
        self.path_xy = [env.agent_xy]
        self.subgoal_xy = None
        self.pending = []
        if self.render_mode == "rgb_array_list":
            self.pending.append(self.draw(env))

    def after_low_level_step(self, env: Any, subgoal_xy: np.ndarray) -> None:
        """Called after every low-level step: extends the path, and (list mode) draws the frame."""
        if self.render_mode is None:
            return
        self.path_xy.append(env.agent_xy)
        self.subgoal_xy = subgoal_xy
        if self.render_mode == "rgb_array_list":
            self.pending.append(self.draw(env))

    def render(self, env: Any) -> np.ndarray | list[np.ndarray] | None:
        """``render()``'s result: the current frame, or the frames since the last call (list mode)."""
        if self.render_mode == "rgb_array":
            return self.draw(env)
        if self.render_mode == "rgb_array_list":
            frames, self.pending = self.pending, []
            return frames
        return None

    def draw(self, env: Any) -> np.ndarray:
        """The current frame of ``env`` in this view."""
        if self.render_view == "schematic":
            return self.birdseye.rgb(env.layout.walls, env.agent_xy, env.goal_xy)
        path = np.asarray(self.path_xy if self.path_xy else [env.agent_xy])
        if self.render_view == "trail":
            return draw_trail_schematic(self.birdseye, env.layout.walls, path, env.goal_xy, self.subgoal_xy)
        if self.mujoco_view is None or self.mujoco_view.geometry != env.geometry:
            self.mujoco_view = MujocoView(env.geometry)
        return self.mujoco_view.frame(env.reach.sim.data, path, env.goal_xy)

    def close(self) -> None:
        """Frees the MuJoCo view's OpenGL context, if one was made."""
        if self.mujoco_view is not None:
            self.mujoco_view.close()
