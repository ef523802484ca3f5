"""Low-level controllers the high-level env can run: SB3 models, plain callables, a scripted point controller."""

from __future__ import annotations

import numbers
from typing import Any, Protocol, runtime_checkable

import numpy as np

GoalObservation = dict[str, np.ndarray]


@runtime_checkable
class LowLevelController(Protocol):
    """Maps a goal observation (``observation``, ``achieved_goal``, ``desired_goal``) to an action.

    A controller with state across steps may also define ``reset()``, taking no arguments: the high-level
    env calls it at the start of every episode, so that one episode's actions never depend on the one before.
    """

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


def reset_controller(controller: Any) -> None:
    """Calls ``controller.reset()`` if it has one (a stateful controller, see :class:`LowLevelController`)."""
    reset = getattr(controller, "reset", None)
    if callable(reset):
        reset()


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


class ActionSmoother:
    """Exponential smoothing of a stream of actions: ``a_t = alpha * a_{t-1} + (1 - alpha) * raw_t``.

    The one implementation of action smoothing, used on the controller's side (:class:`SmoothedController`,
    any controller in any env) and on the env's side (``ReachEnv(action_smoothing=...)``, so that a policy
    is trained under it). The first action after :meth:`reset` is the raw one.

    Args:
        alpha: Weight of the previous action, in ``[0, 1)``; ``0`` passes actions through unchanged.

    Raises:
        ValueError: If ``alpha`` is outside ``[0, 1)``.

    """

    def __init__(self, alpha: float) -> None:
        if not isinstance(alpha, numbers.Real) or not 0.0 <= alpha < 1.0:
            raise ValueError(f"action smoothing alpha must lie in [0, 1), got {alpha!r}")
        self.alpha = float(alpha)
        self._previous: np.ndarray | None = None

    def reset(self) -> None:
        """Forgets the previous action."""
        self._previous = None

    def __call__(self, raw: np.ndarray) -> np.ndarray:
        """Returns the smoothed action for the raw action ``raw``."""
        raw = np.array(raw, dtype=np.float64)  # a copy: a caller reusing its buffer must not change the past
        action = raw if self._previous is None else self.alpha * self._previous + (1.0 - self.alpha) * raw
        self._previous = action
        return action


class SmoothedController:
    """Another controller's actions, clipped to ``[-1, 1]`` and smoothed exponentially (:class:`ActionSmoother`).

    Clipping first makes it the smoothing ``ReachEnv(action_smoothing=alpha)`` applies (which clips each
    action before smoothing), for controllers whose raw output leaves the action range too.

    An inference-time candidate against flips (issue 16): it damps the step-to-step torque jumps of a
    policy trained without smoothing, at the price of a slower response. The smoothing carries across
    subgoals (a new subgoal mid-stride does not reset the legs' torques) and restarts at :meth:`reset`,
    which the high-level env calls at each episode start.

    Args:
        controller: The controller (or SB3 model) whose actions are smoothed.
        alpha: Weight of the previous action, in ``[0, 1)``; ``0`` passes actions through unchanged.

    Raises:
        ValueError: If ``alpha`` is outside ``[0, 1)``.

    """

    def __init__(self, controller: Any, alpha: float) -> None:
        self.smoother = ActionSmoother(alpha)
        self.controller = as_controller(controller)

    @property
    def alpha(self) -> float:
        """Weight of the previous action."""
        return self.smoother.alpha

    def reset(self) -> None:
        """Forgets the previous action (and resets the inner controller, if it has state)."""
        self.smoother.reset()
        reset_controller(self.controller)

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the smoothed action for ``observation``."""
        return self.smoother(np.clip(self.controller(observation), -1.0, 1.0))


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
