"""A high-level maze env whose random layouts all come from one part of the layout partition."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils.ezpickle import EzPickle

from antmaze_hirl.envs.high_level import HighLevelMazeEnv
from antmaze_hirl.envs.layout_splits import LayoutSplit, check_split, sample_layout_in_split
from antmaze_hirl.envs.layouts import MazeLayout


class SplitMazeEnv(HighLevelMazeEnv):
    """:class:`HighLevelMazeEnv` drawing every layout from one part (``"train"``, ``"eval"``, ``"selection"``).

    Overriding :meth:`sample_layout` covers every way a layout is drawn, since :meth:`sample_task`
    draws through it: :meth:`reset` without a ``layout`` option (evaluation) and
    :class:`~antmaze_hirl.dagger.DAggerTrainer`, which calls ``sample_task`` on the env under the
    wrappers (:func:`~antmaze_hirl.envs.protocol.maze_env`); a ``gym.Wrapper`` could intercept neither,
    since both reach the unwrapped env. ``gym.make`` of a maze id with ``split=`` makes one
    (:func:`~antmaze_hirl.sb3_ext.shipped.make_maze_env`). Everything else is the parent's.

    Args:
        split: The part of :mod:`antmaze_hirl.envs.layout_splits` to draw from.
        *args: As :class:`HighLevelMazeEnv`.
        **kwargs: As :class:`HighLevelMazeEnv`.

    Raises:
        ValueError: On an unknown split, or (from the first draw, made at construction) a maze family
            with no wall grid in that part.
    """

    def __init__(self, *args: Any, split: LayoutSplit, **kwargs: Any) -> None:
        # Set first: the parent's constructor already draws a layout through sample_layout.
        self.split = check_split(split)
        super().__init__(*args, **kwargs)
        EzPickle.__init__(self, *args, split=split, **kwargs)  # the parent recorded its arguments without split

    def sample_layout(self, rng: np.random.Generator) -> MazeLayout:
        """Draws a layout of the parent's family, by rejection, until its wall grid lies in :attr:`split`."""
        return sample_layout_in_split(super().sample_layout, rng, self.split)
