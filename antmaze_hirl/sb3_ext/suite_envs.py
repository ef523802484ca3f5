"""Entry point of the benchmark suite ids (``antmaze_hirl/PointMaze-5x5-v0``, ``antmaze_hirl/AntMaze-large-v0``, ...).

Like :func:`antmaze_hirl.sb3_ext.shipped.make_maze_env`, it plugs in the body's shipped low-level policy when
no ``low_level`` is given, so ``gym.make(suite_id)`` plays the suite with the hierarchy every baseline used.
"""

from __future__ import annotations

from typing import Any

from antmaze_hirl.envs.suite_specs import check_suite_name
from antmaze_hirl.envs.suites import SuiteMazeEnv
from antmaze_hirl.sb3_ext.shipped import ShippedPolicyController


def make_suite_env(
    suite: str, *, low_level: Any = None, render_mode: str | None = None, render_view: str = "schematic"
) -> SuiteMazeEnv:
    """The env of benchmark suite ``suite``, with the shipped low level of its body unless ``low_level`` is given.

    ``render_mode`` and ``render_view`` are :class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv`'s.

    Raises:
        ValueError: On an unknown suite, render mode or view.
    """
    spec = check_suite_name(suite)
    controller = ShippedPolicyController(spec.body) if low_level is None else low_level
    return SuiteMazeEnv(suite, low_level=controller, render_mode=render_mode, render_view=render_view)
