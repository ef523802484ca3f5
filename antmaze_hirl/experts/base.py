"""The expert interface shared by the scripted oracle and the human adapter."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Expert(Protocol):
    """Anything that labels a high-level observation with a subgoal; each call is one unit of expert cost."""

    def label(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Returns the expert subgoal ``pi*(s)`` (xy, metres) for ``observation``."""
        ...
