"""Low-level controllers the high-level env can run: SB3 models, plain callables, a scripted point controller."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

GoalObservation = dict[str, np.ndarray]


@runtime_checkable
class LowLevelController(Protocol):
    """Maps a goal observation (``observation``, ``achieved_goal``, ``desired_goal``) to an action."""

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the action for ``observation``."""
        ...


class PredictController:
    """Adapts anything with SB3's ``predict(obs, deterministic=...)`` to a :class:`LowLevelController`.

    Args:
        model: An SB3 model or policy (or any object with the same ``predict``).
        deterministic: Passed to ``predict``; deterministic actions by default.

    """

    def __init__(self, model: Any, *, deterministic: bool = True) -> None:
        self.model = model
        self.deterministic = deterministic

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the model's action for ``observation``."""
        action, _ = self.model.predict(observation, deterministic=self.deterministic)
        return np.asarray(action)


def as_controller(low_level: Any) -> LowLevelController:
    """Wraps ``low_level`` as a controller: SB3-style models via ``predict``, callables as they are.

    Raises:
        TypeError: If ``low_level`` has no ``predict`` and is not callable.

    """
    if hasattr(low_level, "predict"):
        return PredictController(low_level)
    if callable(low_level):
        return low_level
    raise TypeError(
        f"low_level must be an SB3 model (with .predict) or a callable obs -> action, got {type(low_level).__name__}"
    )


class PointGoToController:
    """Scripted PD controller that drives the point mass straight at its subgoal.

    The point's observation holds only its velocity (xy is ``achieved_goal``), so the force is
    ``kp * (subgoal - xy) - kd * velocity``, clipped to the actuator range.

    Args:
        kp: Gain on the position error (per metre).
        kd: Damping on the velocity (per m/s).

    """

    def __init__(self, kp: float = 10.0, kd: float = 1.0) -> None:
        self.kp = kp
        self.kd = kd

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the clipped PD force towards ``desired_goal``."""
        error = observation["desired_goal"] - observation["achieved_goal"]
        return np.clip(self.kp * error - self.kd * observation["observation"][:2], -1.0, 1.0)
