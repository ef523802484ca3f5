"""Deprecated: the experiment's panels moved to :mod:`antmaze_hirl.plotting`, the package's one plotting module.

This module will be removed.
"""

from __future__ import annotations

import warnings

from antmaze_hirl.plotting import draw_band, plot_panels

warnings.warn(
    "antmaze_hirl.experiments.plots is deprecated: import plot_panels and draw_band from antmaze_hirl.plotting",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["draw_band", "plot_panels"]
