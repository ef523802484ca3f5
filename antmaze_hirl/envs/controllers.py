"""Low-level controllers the high-level env can run: SB3 models, plain callables, a scripted point controller."""

from __future__ import annotations

import abc
import contextlib
import copy
import numbers
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from antmaze_hirl.envs.bodies import uprightness

GoalObservation = dict[str, np.ndarray]

SMALL_BATCH_ROWS = 256
"""Inference on at most this many rows runs on one torch thread (:func:`inference_threads`)."""

DIRECT_PREDICT = True
""":class:`PredictController` runs an SB3 policy's ``predict`` steps itself, skipping per-call overhead with
the same actions bit for bit; ``False`` calls ``model.predict`` (``benchmarks/hierarchy_throughput.py``'s
reference rows)."""

_forked_child = False


def _mark_forked_child() -> None:
    # GNU OpenMP (torch's libgomp) is not fork-safe: a child forked after the parent ran a parallel region
    # inherits a thread team whose threads do not exist, and its next multi-threaded BLAS call waits for them
    # forever (Gymnasium's AsyncVectorEnv under the default fork context hung in MKL's gemm_batch so).
    global _forked_child
    _forked_child = True


os.register_at_fork(after_in_child=_mark_forked_child)


@contextlib.contextmanager
def inference_threads(rows: int) -> Iterator[None]:
    """Runs the body on one torch thread when ``rows`` is small, restoring the caller's setting after.

    A small forward pass (a low-level policy acting for one to a few hundred bodies) costs less than waking a second
    thread (docs/guides/vector-envs.md, "Threads", has the timings). One thread gives the same actions bit for bit here
    (checked for batches of 1 to 64). In a process forked from one that had used torch's OpenMP threads, every call runs
    on one thread, whatever ``rows``, since a multi-threaded call there never returns. torch's global setting
    (``torch.get_num_threads()``) is as the caller left it when the body ends; a process without torch loaded is left
    alone.

    Args:
        rows: Number of observations in the forward pass.
    """
    torch = sys.modules.get("torch")
    if torch is None or (rows > SMALL_BATCH_ROWS and not _forked_child):
        yield
        return
    previous = torch.get_num_threads()
    if previous == 1:
        yield
        return
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


@runtime_checkable
class LowLevelController(Protocol):
    """Maps a goal observation (``observation``, ``achieved_goal``, ``desired_goal``) to an action.

    A controller with state across steps may also define ``reset()``, taking no arguments: the high-level
    env calls it at the start of every episode, so that one episode's actions never depend on the one before.
    """

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the action for ``observation``."""
        ...


@runtime_checkable
class BatchActor(Protocol):
    """A stateless controller that also acts for a batch of goal observations in one call.

    ``act_batch`` maps goal observations with a leading axis of ``n`` rows to ``(n, action_dim)`` actions,
    each row as ``__call__`` would give it (up to float rounding).
    """

    def act_batch(self, observations: GoalObservation) -> np.ndarray:
        """Returns one action per row of ``observations``."""
        ...


class PredictController:
    """Adapts anything with SB3's ``predict(obs, deterministic=...)`` to a :class:`LowLevelController`.

    It acts for one observation (``__call__``) or a batch (:meth:`act_batch`, one forward pass), on one
    torch thread for small batches (:func:`inference_threads`).

    Args:
        model: An SB3 model or policy (or any object with the same ``predict``).
        deterministic: Passed to ``predict``; deterministic actions by default.

    """

    def __init__(self, model: Any, *, deterministic: bool = True) -> None:
        self.model = model
        self.deterministic = deterministic
        self._policy = _direct_policy(model)

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """Returns the model's action for ``observation``."""
        with inference_threads(1):
            if DIRECT_PREDICT and self._policy is not None and isinstance(observation, dict):
                return self._act_directly(observation, 1).reshape(self._policy.action_space.shape)
            action, _ = self.model.predict(observation, deterministic=self.deterministic)
        return np.asarray(action)

    def act_batch(self, observations: GoalObservation) -> np.ndarray:
        """Returns the model's actions for a batch, ``(n, action_dim)``, in one forward pass.

        Each row equals :meth:`__call__` on that row up to float rounding: a matrix product over ``n`` rows
        may round the last bits differently from one over a single row.
        """
        rows = len(next(iter(observations.values())))
        with inference_threads(rows):
            if DIRECT_PREDICT and self._policy is not None:
                return self._act_directly(observations, rows)
            actions, _ = self.model.predict(observations, deterministic=self.deterministic)
        return np.asarray(actions).reshape(rows, -1)

    def _act_directly(self, observations: GoalObservation, rows: int) -> np.ndarray:
        # SB3's BasePolicy.predict for a Dict observation and a Box action space, step for step, without what
        # costs a millisecond per call on a loaded machine and changes nothing here: set_training_mode(False)
        # walks every module (the policy is checked to be in eval mode instead), and a deep copy of the
        # observation. The same tensors reach the same _predict, so the actions are the same bit for bit.
        policy = self._policy
        if policy.training:
            policy.set_training_mode(False)
        torch = sys.modules["torch"]
        spaces = policy.observation_space.spaces
        # SB3's device property walks the policy's modules to its first parameter: read once per call, not once
        # per key (the same tensors, so the same actions bit for bit).
        device = policy.device
        with torch.no_grad():
            tensors = {
                key: torch.as_tensor(np.array(value).reshape((-1, *spaces[key].shape)), device=device)
                for key, value in observations.items()
            }
            actions = policy._predict(tensors, deterministic=self.deterministic)
        actions = actions.cpu().numpy().reshape((-1, *policy.action_space.shape))
        if policy.squash_output:
            return policy.unscale_action(actions).reshape(rows, -1)
        return np.clip(actions, policy.action_space.low, policy.action_space.high).reshape(rows, -1)


def _direct_policy(model: Any) -> Any:
    # The SB3 policy of an SB3 model (or the policy itself) whose predict PredictController may run
    # directly: Dict observations without images, a Box action space; None for anything else (predict is used).
    policy = getattr(model, "policy", model)
    needed = ("_predict", "unscale_action", "set_training_mode", "observation_space", "action_space", "device")
    if not all(hasattr(policy, name) for name in needed) or "torch" not in sys.modules:
        return None
    observation_space, action_space = policy.observation_space, policy.action_space
    if type(action_space).__name__ != "Box" or type(observation_space).__name__ != "Dict":
        return None
    for space in observation_space.spaces.values():
        if type(space).__name__ != "Box" or len(space.shape) != 1:  # images would need SB3's transposing
            return None
    return policy


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

    An inference-time candidate against the ant's flips in mazes: it damps the step-to-step torque jumps of a
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

    def batched(self, num_envs: int) -> BatchController:
        """A batch controller for ``num_envs`` sub-envs: the inner controller batched, one smoother per sub-env."""
        return _SmoothedBatch(as_batch_controller(self.controller, num_envs), self.alpha, num_envs)


ANT_QUATERNION_INDEX = 1
"""Where the torso quaternion ``(qw, qx, qy, qz)`` starts in the ant's ``observation`` (after the torso height)."""


class TiltDampedController:
    """Another controller's actions, clipped to ``[-1, 1]`` and scaled down while the ant's torso tilts.

    A default-off safety filter against the ant's flips (nothing uses it unless wrapped so explicitly). Its
    input is the *uprightness* of the torso, the world z of its up axis (1 upright, 0 on its side), read from
    the torso quaternion in the observation. At or above ``upper_uprightness`` the actions pass unchanged; at or
    below ``lower_uprightness`` they are multiplied by ``min_scale``; in between the multiplier falls
    linearly. Stateless: each row of a batch is damped by its own uprightness, so it batches with its
    inner controller (:meth:`batched`). What it changes is fixed by hand (the three numbers); the policy
    it wraps is unchanged.

    Why a candidate: a flipping ant pushes harder while it tilts than one that recovers from the same tilt, so
    less torque once it tilts might let it settle. ``results/steady_ant/README.md`` (the session-29 flip diagnosis)
    measured whether it does.

    Args:
        controller: The controller (or SB3 model) whose actions are damped.
        upper_uprightness: Uprightness at or above which actions pass unchanged, in ``(-1, 1]``.
        lower_uprightness: Uprightness at or below which actions are scaled by ``min_scale``; below ``upper``.
        min_scale: The multiplier at ``lower_uprightness`` and below, in ``[0, 1]``.
        quaternion_index: Where the torso quaternion starts in ``observation`` (the ant's layout by default).

    Raises:
        ValueError: If the uprightness bounds are not ``-1 <= lower < upper <= 1``, ``min_scale`` is outside
            ``[0, 1]``, or ``quaternion_index`` is negative.
    """

    def __init__(
        self,
        controller: Any,
        *,
        upper_uprightness: float,
        lower_uprightness: float,
        min_scale: float,
        quaternion_index: int = ANT_QUATERNION_INDEX,
    ) -> None:
        if not -1.0 <= lower_uprightness < upper_uprightness <= 1.0:
            raise ValueError(
                f"tilt damping needs -1 <= lower_uprightness < upper_uprightness <= 1, got lower "
                f"{lower_uprightness!r} and upper {upper_uprightness!r}"
            )
        if not 0.0 <= min_scale <= 1.0:
            raise ValueError(f"tilt damping min_scale must lie in [0, 1], got {min_scale!r}")
        if quaternion_index < 0:
            raise ValueError(f"quaternion_index must be >= 0, got {quaternion_index!r}")
        self.controller = as_controller(controller)
        self.upper_uprightness = float(upper_uprightness)
        self.lower_uprightness = float(lower_uprightness)
        self.min_scale = float(min_scale)
        self.quaternion_index = int(quaternion_index)

    def scale(self, body_observations: np.ndarray) -> np.ndarray:
        """The action multiplier for each row of ``body_observations`` (``(n, dim)``, or one ``(dim,)`` row)."""
        quaternion = np.asarray(body_observations, dtype=np.float64)[
            ..., self.quaternion_index : self.quaternion_index + 4
        ]
        upright = uprightness(quaternion)
        share = (upright - self.lower_uprightness) / (self.upper_uprightness - self.lower_uprightness)
        return self.min_scale + (1.0 - self.min_scale) * np.clip(share, 0.0, 1.0)

    def reset(self) -> None:
        """Resets the inner controller, if it has state (this filter has none)."""
        reset_controller(self.controller)

    def __call__(self, observation: GoalObservation) -> np.ndarray:
        """The inner controller's action for ``observation``, clipped and damped by the torso's tilt."""
        action = np.clip(np.asarray(self.controller(observation), dtype=np.float64), -1.0, 1.0)
        return self.scale(observation["observation"]) * action

    def batched(self, num_envs: int) -> BatchController:
        """A batch controller for ``num_envs`` sub-envs: the inner controller batched, each row damped by its tilt."""
        return _TiltDampedBatch(as_batch_controller(self.controller, num_envs), self)


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
        return np.clip(self.kp * error - self.kd * observation["observation"][..., :2], -1.0, 1.0)

    def act_batch(self, observations: GoalObservation) -> np.ndarray:
        """The same force for each row of a batch (elementwise, so each row equals :meth:`__call__` exactly)."""
        return self(observations)


class BatchController(abc.ABC):
    """Acts for the sub-envs of a vector env: one call for every sub-env still walking to its subgoal.

    Made by :func:`as_batch_controller`. ``reset(index)`` restarts one sub-env's state at its episode start,
    as the high-level env's ``reset()`` restarts a stateful controller.
    """

    @abc.abstractmethod
    def __call__(self, observations: GoalObservation, env_indices: np.ndarray) -> np.ndarray:
        """Actions ``(len(env_indices), action_dim)``; row ``k`` of ``observations`` is sub-env ``env_indices[k]``'s."""

    def reset(self, env_index: int) -> None:
        """Restarts sub-env ``env_index``'s controller state (no-op for a stateless controller)."""
        del env_index  # stateless by default


class _ActorBatch(BatchController):
    # A stateless controller with act_batch: one call for all rows.
    def __init__(self, actor: BatchActor) -> None:
        self.actor = actor

    def __call__(self, observations: GoalObservation, env_indices: np.ndarray) -> np.ndarray:
        return np.asarray(self.actor.act_batch(observations))


class LoopBatchController(BatchController):
    """Sub-env ``i``'s rows go to ``controllers[i]``, one call per row (for controllers that cannot batch).

    Args:
        controllers: One controller per sub-env (the same object may repeat when it has no state).
    """

    def __init__(self, controllers: Sequence[Any]) -> None:
        self.controllers = list(controllers)

    def __call__(self, observations: GoalObservation, env_indices: np.ndarray) -> np.ndarray:
        """Each row's action from its sub-env's controller."""
        rows = [{key: value[k] for key, value in observations.items()} for k in range(len(env_indices))]
        return np.stack([np.asarray(self.controllers[i](row)) for i, row in zip(env_indices, rows, strict=True)])

    def reset(self, env_index: int) -> None:
        """Resets sub-env ``env_index``'s controller, if it has state."""
        reset_controller(self.controllers[env_index])


class _SmoothedBatch(BatchController):
    # SmoothedController's batch form: the inner batch, then each sub-env's own smoother on its row.
    def __init__(self, inner: BatchController, alpha: float, num_envs: int) -> None:
        self.inner = inner
        self.smoothers = [ActionSmoother(alpha) for _ in range(num_envs)]

    def __call__(self, observations: GoalObservation, env_indices: np.ndarray) -> np.ndarray:
        raw = np.clip(self.inner(observations, env_indices), -1.0, 1.0)
        return np.stack([self.smoothers[i](row) for i, row in zip(env_indices, raw, strict=True)])

    def reset(self, env_index: int) -> None:
        self.smoothers[env_index].reset()
        self.inner.reset(env_index)


class _TiltDampedBatch(BatchController):
    # TiltDampedController's batch form: the inner batch, then each row scaled by its own uprightness.
    def __init__(self, inner: BatchController, damping: TiltDampedController) -> None:
        self.inner = inner
        self.damping = damping

    def __call__(self, observations: GoalObservation, env_indices: np.ndarray) -> np.ndarray:
        actions = np.clip(np.asarray(self.inner(observations, env_indices), dtype=np.float64), -1.0, 1.0)
        return self.damping.scale(observations["observation"])[:, None] * actions

    def reset(self, env_index: int) -> None:
        self.inner.reset(env_index)


def as_batch_controller(controller: Any, num_envs: int) -> BatchController:
    """The batch form of ``controller`` (as :func:`as_controller` accepts it) for ``num_envs`` sub-envs.

    * An object with ``batched(num_envs)`` (:class:`SmoothedController`, :class:`TiltDampedController`) makes its own.
    * A stateless :class:`BatchActor` (:class:`PredictController`, :class:`PointGoToController`, SB3 models)
      acts for all rows in one call.
    * Any other callable cannot batch: it is called row by row, with a one-line warning; one with a
      ``reset()`` (state across steps) is deep-copied per sub-env, so that sub-envs never share its state.

    Raises:
        ValueError: If ``num_envs`` < 1.
        TypeError: If ``controller`` is neither an SB3-style model nor a callable.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    controller = as_controller(controller)
    batched = getattr(controller, "batched", None)
    if callable(batched):
        return batched(num_envs)
    if isinstance(controller, BatchActor):
        return _ActorBatch(controller)
    warnings.warn(
        f"low-level controller {type(controller).__name__} has no act_batch: the vector env calls it once per "
        "sub-env and step (give it act_batch(observations) -> (n, action_dim) actions to batch)",
        stacklevel=2,
    )
    stateful = callable(getattr(controller, "reset", None))
    return LoopBatchController([copy.deepcopy(controller) if stateful else controller for _ in range(num_envs)])
