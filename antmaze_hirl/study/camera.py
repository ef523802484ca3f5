"""A MuJoCo camera view of the ant for the study page, where OpenGL rendering works (``MUJOCO_GL=egl`` headless)."""

from __future__ import annotations

import io
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np


class CameraUnavailable(RuntimeError):
    """No camera view: not the ant, or no OpenGL backend here (the page then shows the bird's-eye view alone)."""


class AntCamera:
    """Renders a tracking view of the ant's torso as PNG bytes.

    An OpenGL context belongs to the thread that made it, while the server answers on many threads,
    so one worker thread owns the renderer and does every render.

    Args:
        width: Image width, pixels.
        height: Image height, pixels.
    """

    def __init__(self, width: int = 320, height: int = 240) -> None:
        if not os.environ.get("MUJOCO_GL"):
            # Without it MuJoCo tries a windowed (GLFW) context, which a headless machine lacks.
            raise CameraUnavailable("camera view needs OpenGL: start the server with MUJOCO_GL=egl (or osmesa)")
        self.width, self.height = width, height
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mujoco-camera")
        self._renderer: Any = None
        self._model: Any = None

    def frame(self, data: Any) -> bytes:
        """The current view of the simulation ``data`` (a ``mujoco.MjData``) as PNG.

        Raises:
            CameraUnavailable: If OpenGL rendering fails here.
        """
        return self._worker.submit(self._render, data).result()

    def _render(self, data: Any) -> bytes:
        import mujoco
        from PIL import Image

        try:
            if self._renderer is None or self._model is not data.model:
                if self._renderer is not None:
                    self._renderer.close()
                self._renderer = mujoco.Renderer(data.model, self.height, self.width)
                self._model = data.model
            camera = mujoco.MjvCamera()
            camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            camera.trackbodyid = 1  # the torso: body 0 is the world
            camera.distance, camera.elevation, camera.azimuth = 7.0, -35.0, 90.0
            self._renderer.update_scene(data, camera=camera)
            pixels = np.asarray(self._renderer.render())
        except Exception as error:  # any GL failure means: no camera here
            raise CameraUnavailable(f"MuJoCo could not render here: {error}") from error
        buffer = io.BytesIO()
        Image.fromarray(pixels).save(buffer, format="PNG")
        return buffer.getvalue()

    def close(self) -> None:
        """Frees the renderer and its thread."""
        if self._renderer is not None:
            self._worker.submit(self._renderer.close).result()
            self._renderer = None
        self._worker.shutdown()
