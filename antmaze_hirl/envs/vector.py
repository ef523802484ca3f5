"""Vector envs: many high-level mazes whose low levels step in lockstep behind one batched controller call.

:class:`HighLevelVectorEnv` is a Gymnasium :class:`~gymnasium.vector.VectorEnv` over ``N``
:class:`~antmaze_hirl.envs.high_level.HighLevelMazeEnv` sub-envs. One :meth:`~HighLevelVectorEnv.step`
takes ``N`` subgoals and walks every sub-env's low level towards its own: each low-level step gathers the
goal observations of the sub-envs still walking and asks the controller for all their actions in one call
(:func:`~antmaze_hirl.envs.controllers.as_batch_controller`); a sub-env whose walk is over waits for the
others. Each sub-env runs exactly the parts of its serial ``step`` (``check_subgoal``, ``start_walk``,
``advance_subgoal``, ``end_subgoal``), so with a controller that acts row by row the sub-envs give the
serial env's episodes bit for bit; a batched forward pass may round the last bits differently.

The registered ids use it as their ``vector_entry_point``
(:func:`antmaze_hirl.sb3_ext.shipped.make_maze_vector_env`), so
``gym.make_vec("antmaze_hirl/AntMaze-v0", num_envs=N)`` returns one.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from antmaze_hirl.envs.controllers import BatchController, LoopBatchController, as_batch_controller
from antmaze_hirl.envs.high_level import HighLevelMazeEnv, SubgoalWalk
from antmaze_hirl.envs.reach import ReachEnv


def check_num_envs(num_envs: Any) -> int:
    """``num_envs`` as an int.

    Raises:
        ValueError: If it is not an integer >= 1.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
        raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
    return int(num_envs)


def check_episodes_and_num_envs(episodes: int, num_envs: Any) -> int:
    """``num_envs`` as an int (:func:`check_num_envs`), once an evaluation's ``episodes`` is checked too.

    Raises:
        ValueError: If ``episodes`` is below 1, or ``num_envs`` is not an integer >= 1.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    return check_num_envs(num_envs)


def _autoreset_mode(mode: AutoresetMode | str) -> AutoresetMode:
    try:
        return AutoresetMode(mode)
    except ValueError:
        names = [member.value for member in AutoresetMode]
        raise ValueError(f"autoreset_mode must be one of {names}, got {mode!r}") from None


def walk_in_lockstep(
    envs: Sequence[HighLevelMazeEnv], walks: dict[int, SubgoalWalk], low_level: BatchController
) -> None:
    """Advances every walk until it is done: one ``low_level`` call per low-level step for the walks not done.

    Args:
        envs: The sub-envs; ``walks[i]`` was started by ``envs[i].start_walk`` (or ``begin_subgoal``).
        walks: The sub-envs' walks, by sub-env index.
        low_level: The batch controller; it gets the goal observations of the walking sub-envs, in index order.
    """
    active = sorted(index for index, walk in walks.items() if not walk.done)
    while active:
        first = walks[active[0]].low_obs
        observations = {key: np.stack([walks[index].low_obs[key] for index in active]) for key in first}
        low_actions = low_level(observations, np.asarray(active))
        for row, index in enumerate(active):
            envs[index].advance_subgoal(walks[index], low_actions[row])
        active = [index for index in active if not walks[index].done]


def copies_of(env: Any, count: int) -> list[HighLevelMazeEnv]:
    """``count`` new high-level envs made with ``env``'s own arguments, sharing its low-level controller.

    ``env`` (wrapped or not) must be a :class:`HighLevelMazeEnv` or a subclass that records its arguments
    with ``EzPickle`` (as :class:`~antmaze_hirl.envs.split_env.SplitMazeEnv` does); a copy reset with a seed
    plays the episode ``env`` would play with that seed.

    Raises:
        ValueError: If ``env`` is no such env, or ``count`` < 1.
    """
    inner = getattr(env, "unwrapped", env)
    if not isinstance(inner, HighLevelMazeEnv):
        raise ValueError(f"lockstep copies need a HighLevelMazeEnv, got {type(inner).__name__}")
    count = check_num_envs(count)
    kwargs = {**inner._ezpickle_kwargs, "low_level": inner.controller}  # one controller for all: it batches
    return [type(inner)(*inner._ezpickle_args, **kwargs) for _ in range(count)]


class HighLevelVectorEnv(VectorEnv):
    """``N`` high-level mazes stepped together, their low levels in lockstep (one controller call per low-level step).

    Autoreset follows Gymnasium's modes (``metadata["autoreset_mode"]``):

    * ``"NextStep"`` (the default, as Gymnasium's own vector envs): a sub-env whose episode ended is reset
      on the next :meth:`step`, which ignores its action there and returns its first observation with
      reward 0 and ``terminated = truncated = False``.
    * ``"SameStep"``: it is reset within the step that ended it; that step returns the new episode's first
      observation, and the last one in ``infos["final_obs"]`` and ``infos["final_info"]``.
    * ``"Disabled"``: never reset by :meth:`step`; reset sub-envs with ``reset(options={"reset_mask": mask})``.

    Infos are stacked as Gymnasium does (``infos[key][i]``, with mask ``infos["_" + key]``); each
    high-level step's ``agent_path`` is an :class:`~antmaze_hirl.envs.high_level.AgentPath`, kept in an
    object array since its length differs between sub-envs.

    Args:
        envs: The sub-envs (unwrapped), all with the same spaces. Their low-level controller should be one
            shared object: it is batched once for all (:func:`~antmaze_hirl.envs.controllers.as_batch_controller`).
            Sub-envs with controllers of their own are stepped one call per sub-env (with a warning).
        autoreset_mode: One of the above.
        max_episode_steps: ``None`` for no limit, else the high-level steps (subgoals) after which an episode
            is truncated, as Gymnasium's ``TimeLimit`` does for ``gym.make`` (the suite ids register one; the
            sub-envs are unwrapped, so the vector env counts it itself).

    Raises:
        ValueError: With no sub-env, sub-envs whose spaces differ, an unknown ``autoreset_mode`` or a
            ``max_episode_steps`` below 1.
    """

    def __init__(
        self,
        envs: Sequence[HighLevelMazeEnv],
        *,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
    ) -> None:
        self.envs = list(envs)
        self.num_envs = check_num_envs(len(self.envs))
        first = self.envs[0]
        for index, env in enumerate(self.envs[1:], start=1):
            if env.observation_space != first.observation_space or env.action_space != first.action_space:
                raise ValueError(f"sub-env {index} has other spaces than sub-env 0: every maze needs the same size")
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = first.render_mode
        controllers = [env.controller for env in self.envs]
        if all(controller is controllers[0] for controller in controllers):
            self.low_level: BatchController = as_batch_controller(controllers[0], self.num_envs)
        else:
            warnings.warn(
                "the sub-envs have low-level controllers of their own: the vector env calls them one by one "
                "(share one controller object to batch them)",
                stacklevel=2,
            )
            self.low_level = LoopBatchController(controllers)
        self._observations: list[dict[str, np.ndarray] | None] = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        if max_episode_steps is not None and (isinstance(max_episode_steps, bool) or max_episode_steps < 1):
            raise ValueError(f"max_episode_steps must be None or an integer >= 1, got {max_episode_steps!r}")
        self.max_episode_steps = max_episode_steps
        self._episode_steps = np.zeros(self.num_envs, dtype=np.int64)

    def reset(
        self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Resets every sub-env (or those of ``options["reset_mask"]``).

        Args:
            seed: ``None``, an int (sub-env ``i`` gets ``seed + i``) or one seed per sub-env.
            options: Passed to every sub-env's reset (``"layout"``, ``"start_xy"``, ``"goal_xy"``), except
                ``"reset_mask"``, a boolean array of the sub-envs to reset (the others keep their state).

        Raises:
            ValueError: If ``seed`` or ``reset_mask`` has another length than ``num_envs``.
        """
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", np.ones(self.num_envs, dtype=bool)), dtype=bool)
        if mask.shape != (self.num_envs,):
            raise ValueError(f"reset_mask must be {self.num_envs} booleans, got shape {mask.shape}")
        if seed is None or isinstance(seed, int | np.integer):
            seeds = [None if seed is None else int(seed) + index for index in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed needs one entry per sub-env ({self.num_envs}), got {len(seeds)}")
        infos: dict[str, Any] = {}
        for index in np.flatnonzero(mask):
            self._observations[index], info = self._reset_one(index, seeds[index], options or None)
            infos = self._add_info(infos, info, index)
        self._autoreset[mask] = False
        return self._stacked(), infos

    def step(
        self, actions: np.ndarray
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One high-level step of every sub-env: each walks to its subgoal ``actions[i]`` (in lockstep).

        Raises:
            ValueError: If ``actions`` is not ``(num_envs, 2)``, or a subgoal is NaN/inf or outside the maze
                (unless the sub-envs clip); then no sub-env has moved.
        """
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {actions.shape}")
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminations = np.zeros(self.num_envs, dtype=bool)
        truncations = np.zeros(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        walking = [index for index in range(self.num_envs) if not self._autoreset[index]]
        checked = {index: self.envs[index].check_subgoal(actions[index]) for index in walking}  # all, before any moves
        for index in range(self.num_envs):
            if self._autoreset[index]:  # NextStep: this step resets it and ignores its action
                self._observations[index], info = self._reset_one(index, None, None)
                infos = self._add_info(infos, info, index)
        walks = {index: self.envs[index].start_walk(*checked[index]) for index in walking}
        walk_in_lockstep(self.envs, walks, self.low_level)
        for index, walk in walks.items():
            obs, rewards[index], terminations[index], truncations[index], info = self.envs[index].end_subgoal(walk)
            self._episode_steps[index] += 1
            if self.max_episode_steps is not None and self._episode_steps[index] >= self.max_episode_steps:
                truncations[index] = True  # as TimeLimit: truncated even when the step also terminated
            if self.autoreset_mode == AutoresetMode.SAME_STEP and (terminations[index] or truncations[index]):
                infos = self._add_info(infos, {"final_obs": obs, "final_info": info}, index)
                obs, info = self._reset_one(index, None, None)
            self._observations[index] = obs
            infos = self._add_info(infos, info, index)
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._autoreset = terminations | truncations
        return self._stacked(), rewards, terminations, truncations, infos

    def _reset_one(
        self, index: int, seed: int | None, options: dict[str, Any] | None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        obs, info = self.envs[index].reset(seed=seed, options=options)
        self._episode_steps[index] = 0
        self.low_level.reset(index)  # each sub-env's controller state starts afresh with its episode
        return obs, info

    def _stacked(self) -> dict[str, np.ndarray]:
        out = create_empty_array(self.single_observation_space, self.num_envs)
        return concatenate(self.single_observation_space, self._observations, out)

    def render(self) -> tuple[np.ndarray | None, ...] | None:
        """Every sub-env's bird's-eye picture when ``render_mode="rgb_array"``."""
        if self.render_mode is None:
            return None
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        """Closes every sub-env."""
        for env in self.envs:
            env.close()


def make_high_level_vector_env(
    num_envs: int, make_env: Callable[[], HighLevelMazeEnv], *, autoreset_mode: AutoresetMode | str = "NextStep"
) -> HighLevelVectorEnv:
    """A :class:`HighLevelVectorEnv` of ``num_envs`` sub-envs from ``make_env`` (which should share one controller).

    Raises:
        ValueError: If ``num_envs`` is not an integer >= 1 (before any sub-env is made).
    """
    num_envs = check_num_envs(num_envs)
    return HighLevelVectorEnv([make_env() for _ in range(num_envs)], autoreset_mode=autoreset_mode)


def make_reach_vector_env(
    num_envs: int, *, autoreset_mode: AutoresetMode | str = "NextStep", **kwargs: Any
) -> SyncVectorEnv:
    """``vector_entry_point`` of the reach ids: ``num_envs`` :class:`ReachEnv` in a Gymnasium ``SyncVectorEnv``.

    A reach env has no low level inside (the caller's policy is the low level), so there is nothing to
    batch within it: the caller batches its own policy over the stacked observations.

    Args:
        num_envs: Number of sub-envs, >= 1.
        autoreset_mode: A Gymnasium autoreset mode (default ``"NextStep"``).
        **kwargs: :class:`ReachEnv` keywords.

    Raises:
        ValueError: If ``num_envs`` is not an integer >= 1.
    """
    num_envs = check_num_envs(num_envs)
    mode = _autoreset_mode(autoreset_mode)
    return SyncVectorEnv([lambda: ReachEnv(**kwargs) for _ in range(num_envs)], autoreset_mode=mode)
