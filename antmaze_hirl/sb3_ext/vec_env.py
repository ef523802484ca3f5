"""A Gymnasium vector env as a Stable-Baselines3 ``VecEnv``, so SB3 algorithms train on the lockstep mazes.

SB3 does not take a Gymnasium :class:`~gymnasium.vector.VectorEnv`: its ``VecEnv`` resets a finished
sub-env within the step that ended it and returns the last observation in ``infos[i]["terminal_observation"]``.
That is Gymnasium's ``"SameStep"`` autoreset, so :func:`make_sb3_vec_env` makes the vector env in that mode,
and like SB3's own ``make_vec_env`` it seeds the sub-envs and wraps them in a ``VecMonitor``, so TensorBoard
gets ``rollout/ep_rew_mean`` and ``rollout/ep_len_mean``::

    from stable_baselines3 import PPO
    from antmaze_hirl.sb3_ext.vec_env import make_sb3_vec_env

    venv = make_sb3_vec_env("antmaze_hirl/PointMaze-v0", 8, seed=0, maze_size=3, normalize_actions=True)
    PPO("MultiInputPolicy", venv, n_steps=64, seed=0).learn(1_000)
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from stable_baselines3.common.vec_env import VecMonitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn


class GymnasiumVecEnv(VecEnv):
    """SB3's ``VecEnv`` over a Gymnasium vector env with ``"SameStep"`` autoreset.

    Args:
        env: The vector env (``metadata["autoreset_mode"]`` must be ``AutoresetMode.SAME_STEP``).

    Raises:
        ValueError: If ``env`` resets in another mode.
    """

    def __init__(self, env: VectorEnv) -> None:
        mode = env.metadata.get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise ValueError(
                f"SB3 needs a vector env with autoreset_mode 'SameStep' (the finished sub-env reset within its last "
                f"step), got {mode!r}; make it with gym.make_vec(..., autoreset_mode='SameStep')"
            )
        self.env = env
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> VecEnvObs:
        """Resets every sub-env (with the seeds given to :meth:`seed`, once; SB3's reset options are not passed)."""
        seeds = list(self._seeds) if any(seed is not None for seed in self._seeds) else None
        obs, infos = self.env.reset(seed=seeds)
        self.reset_infos = self._split_infos(infos)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Keeps the actions for :meth:`step_wait`."""
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        """Steps every sub-env; finished ones come back reset, their last observation in ``terminal_observation``."""
        obs, rewards, terminated, truncated, infos = self.env.step(self._actions)
        dones = terminated | truncated
        split = self._split_infos(infos)
        for index in np.flatnonzero(dones):
            self.reset_infos[index] = split[index]  # the new episode's, as SB3's DummyVecEnv keeps them
            split[index] = self._final_info(infos, index)  # the finished step's info (is_success, ...)
            split[index]["terminal_observation"] = infos["final_obs"][index]
            split[index]["TimeLimit.truncated"] = bool(truncated[index] and not terminated[index])
        return obs, rewards.astype(np.float32), dones, split

    def _split_infos(self, infos: dict[str, Any]) -> list[dict[str, Any]]:
        # Gymnasium's stacked infos (value arrays with "_key" masks) as one dict per sub-env.
        split: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for key, values in infos.items():
            if key.startswith("_") or key in ("final_obs", "final_info"):
                continue
            mask = infos.get(f"_{key}", np.ones(self.num_envs, dtype=bool))
            for index in np.flatnonzero(mask):
                split[index][key] = values[index]
        return split

    def _final_info(self, infos: dict[str, Any], index: int) -> dict[str, Any]:
        final = infos.get("final_info", {})
        return {key: value[index] for key, value in final.items() if key[0] != "_" and final[f"_{key}"][index]}

    def close(self) -> None:
        """Closes the vector env."""
        self.env.close()

    def _sub_envs(self, indices: VecEnvIndices) -> list[Any]:
        envs = getattr(self.env.unwrapped, "envs", None)  # under any vector wrapper (RescaleAction, ...)
        if envs is None:
            raise AttributeError(f"{type(self.env).__name__} does not expose its sub-envs")
        return [envs[index] for index in self._get_indices(indices)]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """An attribute of each sub-env."""
        return [getattr(env, attr_name) for env in self._sub_envs(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Sets an attribute of each sub-env."""
        for env in self._sub_envs(indices):
            setattr(env, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any) -> list:
        """Calls a method of each sub-env."""
        return [getattr(env, method_name)(*method_args, **kwargs) for env in self._sub_envs(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """Whether each sub-env is wrapped by ``wrapper_class`` (the lockstep env's sub-envs never are)."""
        return [isinstance(env, wrapper_class) for env in self._sub_envs(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Each sub-env's picture (``render_mode="rgb_array"``)."""
        return list(self.env.render() or [None] * self.num_envs)


def make_sb3_vec_env(
    env_id: str,
    num_envs: int = 1,
    *,
    seed: int | None = None,
    monitor_dir: str | None = None,
    monitor_kwargs: dict[str, Any] | None = None,
    **kwargs: Any,
) -> VecEnv:
    """``gym.make_vec(env_id, num_envs, autoreset_mode="SameStep", **kwargs)`` as an SB3 ``VecEnv``, monitored.

    The counterpart of SB3's ``make_vec_env`` for the native vector envs: one process, the sub-envs' low
    levels in lockstep.

    Args:
        env_id: A registered id (every ``antmaze_hirl/...`` id has a native vector env).
        num_envs: Number of sub-envs, >= 1.
        seed: As SB3's ``make_vec_env``: sub-env ``i`` is reset with ``seed + i`` on the first ``reset()``,
            and the action space is seeded with ``seed``. ``None``: unseeded.
        monitor_dir: Where SB3's ``VecMonitor`` writes ``monitor.csv`` (``None``: it keeps the statistics
            in memory only). Either way each finished episode's ``info["episode"]`` is filled, so SB3 logs
            ``rollout/ep_rew_mean`` and ``rollout/ep_len_mean``.
        monitor_kwargs: More ``VecMonitor`` keywords (``info_keywords=("is_success",)``, ...).
        **kwargs: The id's keywords (``maze_size``, ``low_level``, ``clip_subgoals``; for the maze ids,
            ``normalize_actions=True`` for subgoals in ``[-1, 1]``, the space SB3's ``check_env`` asks for).

    Raises:
        ValueError: As ``gym.make_vec`` of ``env_id`` (``num_envs`` below 1, unknown keywords' values).
    """
    venv = GymnasiumVecEnv(gym.make_vec(env_id, num_envs, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs))
    if seed is not None:
        venv.seed(seed)
        venv.action_space.seed(seed)
    filename = None
    if monitor_dir is not None:
        Path(monitor_dir).mkdir(parents=True, exist_ok=True)
        filename = str(Path(monitor_dir) / "monitor.csv")
    return VecMonitor(venv, filename=filename, **(monitor_kwargs or {}))
