"""Low-level training with SB3's own TD3/DDPG/SAC (or sb3-contrib's TQC) and ``HerReplayBuffer``, plus checkpoints."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import DDPG, SAC, TD3, HerReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.envs.reach import INFO_PENALTIES, ReachEnv
from antmaze_hirl.sb3_ext.action_penalty import ActionPenaltyPolicy
from antmaze_hirl.sb3_ext.checkpoint import RunCheckpointCallback, latest_checkpoint
from antmaze_hirl.sb3_ext.config import ALGOS, LowLevelConfig, load_config
from antmaze_hirl.sb3_ext.ensemble import EnsemblePolicy
from antmaze_hirl.sb3_ext.evaluation import SuccessRateCallback
from antmaze_hirl.sb3_ext.extractors import RelativeGoalExtractor
from antmaze_hirl.sb3_ext.loading import algorithm_of, load_low_level, low_level_path, policy_class_of, save_policy
from antmaze_hirl.sb3_ext.warm_start import with_warm_start

# TQC is looked up on use (algo_class): sb3-contrib is an optional extra.
ALGO_CLASSES: dict[str, type[OffPolicyAlgorithm]] = {"td3": TD3, "ddpg": DDPG, "sac": SAC}


def algo_class(algo: str) -> type[OffPolicyAlgorithm]:
    """SB3 class for ``"td3"``, ``"ddpg"``, ``"sac"`` or ``"tqc"`` (sb3-contrib's).

    Raises:
        ValueError: For any other name, or ``"tqc"`` without sb3-contrib installed.

    """
    if algo == "tqc":
        try:
            from sb3_contrib import TQC
        except ImportError as error:
            raise ValueError("--algo tqc needs sb3-contrib: pip install 'antmaze_hirl[tqc]'") from error
        return TQC
    if algo not in ALGO_CLASSES:
        raise ValueError(f"unknown algo {algo!r}; choose one of {list(ALGOS)}")
    return ALGO_CLASSES[algo]


def make_reach_env(body: str, config: LowLevelConfig) -> Monitor:
    """The training env: a :class:`ReachEnv` with the config's env keywords, under SB3's ``Monitor``."""
    return Monitor(ReachEnv(body, **config.env_kwargs))


def policy_kwargs(config: LowLevelConfig) -> dict[str, Any]:
    """SB3 ``policy_kwargs`` for ``config``: network sizes, optional relative-goal extractor and action penalty."""
    kwargs: dict[str, Any] = {"net_arch": list(config.net_arch)}
    if config.relative_goal:
        kwargs["features_extractor_class"] = RelativeGoalExtractor
        kwargs["features_extractor_kwargs"] = {"quaternion_index": config.quaternion_index}
    if config.action_l2 > 0:
        kwargs["action_l2"] = config.action_l2
    if config.algo == "tqc":
        kwargs["n_quantiles"] = config.n_quantiles
    return kwargs


SHARED_SB3_KEYS: tuple[str, ...] = (
    "learning_rate",
    "buffer_size",
    "batch_size",
    "gamma",
    "tau",
    "learning_starts",
    "train_freq",
    "gradient_steps",
)
"""The :class:`LowLevelConfig` fields that every SB3 off-policy algorithm takes under the same name, as they are."""


def shared_kwargs(config: LowLevelConfig) -> dict[str, Any]:
    """The constructor keywords every algorithm takes from ``config``: its :data:`SHARED_SB3_KEYS` fields by name."""
    return {key: getattr(config, key) for key in SHARED_SB3_KEYS}


def algo_kwargs(config: LowLevelConfig, n_actions: int) -> dict[str, Any]:
    """The constructor keywords only ``config.algo``'s family takes: exploration noise or entropy settings.

    SAC and TQC explore by sampling their stochastic policy (their entropy term sets how widely), so they
    take no action noise; TD3/DDPG's deterministic actor needs the Gaussian noise.
    """
    if config.algo in ("td3", "ddpg"):
        return {"action_noise": NormalActionNoise(np.zeros(n_actions), config.action_noise_std * np.ones(n_actions))}
    kwargs: dict[str, Any] = {
        "ent_coef": config.ent_coef,
        "target_entropy": config.target_entropy,
        "target_update_interval": config.target_update_interval,
    }
    if config.algo == "tqc":
        kwargs["top_quantiles_to_drop_per_net"] = config.top_quantiles_to_drop_per_net
    return kwargs


def warm_start_kwargs(config: LowLevelConfig) -> dict[str, Any]:
    """The :class:`~antmaze_hirl.sb3_ext.warm_start.WarmStartMixin` keywords ``config`` sets; empty at defaults."""
    kwargs = {"warmup_actions": config.warmup_actions, "actor_frozen_steps": config.actor_frozen_steps}
    return kwargs if kwargs != {"warmup_actions": "uniform", "actor_frozen_steps": 0} else {}


def training_class(algo: str, config: LowLevelConfig) -> type[OffPolicyAlgorithm]:
    """The class that trains ``algo`` under ``config``: SB3's own, or with the warm-start hooks when it sets them."""
    algorithm = algo_class(algo)
    return with_warm_start(algorithm) if warm_start_kwargs(config) else algorithm


def _check_config_algo(config: LowLevelConfig, algo: str) -> None:
    # TD3 and DDPG read the same keys; any other pair would train with keys the config's author did not set.
    if config.algo != algo and {config.algo, algo} != {"td3", "ddpg"}:
        raise ValueError(
            f"the config is for {config.algo}, not {algo}: load it with load_config(body, ..., algo={algo!r})"
        )


def make_model(
    body: str, algo: str, config: LowLevelConfig, *, seed: int, tensorboard_log: str | None = None
) -> OffPolicyAlgorithm:
    """A fresh SB3 TD3/DDPG/SAC (or TQC) with ``HerReplayBuffer`` on the reach env, configured by ``config``.

    Raises:
        ValueError: If ``algo`` is unknown (or TQC is not installed), or ``config`` is for another algorithm.
    """
    _check_config_algo(config, algo)
    algorithm = training_class(algo, config)
    env = make_reach_env(body, config)
    return algorithm(
        # action_l2 > 0 only for TD3/DDPG (the config refuses it for the others): the penalty lives in TD3's critic.
        ActionPenaltyPolicy if config.action_l2 > 0 else "MultiInputPolicy",
        env,
        **shared_kwargs(config),
        **algo_kwargs(config, env.action_space.shape[0]),
        **warm_start_kwargs(config),
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={
            "n_sampled_goal": config.n_sampled_goal,
            "goal_selection_strategy": "future",
            # HER recomputes relabelled rewards from the stored infos; without a copy it passes empty
            # dicts and a flip or tilt penalty would vanish from 80% of the samples. Copying costs time,
            # so only then.
            "copy_info_dict": any(config.env_kwargs.get(key, 0) > 0 for key in INFO_PENALTIES),
        },
        policy_kwargs=policy_kwargs(config),
        tensorboard_log=tensorboard_log,
        seed=seed,
        verbose=0,
    )


def train_low_level(
    body: str,
    algo: str,
    total_timesteps: int,
    out_dir: str | Path,
    *,
    seed: int = 0,
    resume: bool = False,
    config: LowLevelConfig | None = None,
    init_from: str | Path | None = None,
    init_buffer: str | Path | None = None,
    checkpoint_freq: int = 50_000,
    eval_freq: int = 25_000,
    eval_episodes: int = 50,
    snapshots: bool = True,
    progress_bar: bool = True,
    extra_callbacks: list[BaseCallback] | None = None,
) -> OffPolicyAlgorithm:
    """Trains (or resumes) a low-level policy until ``total_timesteps`` environment steps in all.

    Writes ``out_dir/checkpoints/`` (see :mod:`antmaze_hirl.sb3_ext.checkpoint`),
    ``out_dir/learning_curve.csv``, the policy of every evaluation as ``out_dir/snapshots/step_<n>.zip``,
    TensorBoard logs in ``out_dir/tb`` and the final policy ``out_dir/policy.zip`` (model only, no replay
    buffer: what ships and what ``eval-low`` loads).

    A fine-tune of ``init_from`` may set ``config.warmup_actions = "policy"`` (fill the buffer up to
    ``learning_starts`` with the warm policy's own noisy actions, not uniform ones) and, for TD3/DDPG,
    ``config.actor_frozen_steps`` (its first gradient steps fit the critics only); see
    :mod:`antmaze_hirl.sb3_ext.warm_start`. They are part of the config, so the checkpoint keeps them and
    ``resume`` needs the same.

    Args:
        body: ``"ant"`` or ``"point"``.
        algo: ``"td3"``, ``"ddpg"``, ``"sac"`` or ``"tqc"`` (with sb3-contrib installed).
        total_timesteps: Target step count, counting steps done before a resume.
        out_dir: Run folder.
        seed: Seed of the model and envs.
        resume: Continue from the latest checkpoint in ``out_dir`` (error if there is none or it was
            made with another body, algo, seed or config).
        config: Hyperparameters for ``algo``; default :func:`load_config` for ``body`` and ``algo``.
        init_from: Warm start: a ``.zip`` (or a low-level name, such as the point's ``shipped``) of the same
            algorithm (a TD3 zip for TD3 or DDPG) with the same networks, for the same body, whose weights and
            optimiser states the new model starts from (its replay buffer starts empty; see
            :func:`warm_start_parameters`). On resume it may be left out (the checkpoint holds the weights); if
            given, it must be the one the run started from.
        init_buffer: Warm start's replay buffer: another run's checkpoint ``replay_buffer.pkl`` (a
            ``HerReplayBuffer`` of the same observation and action shapes), so that a fine-tune's critic
            does not relearn from an empty buffer. HER relabels its transitions with this run's reward,
            from their stored infos (an entry they lack counts as its default: a buffer recorded without
            ``info["uprightness"]`` carries no tilt penalty); its unrelabelled transitions keep their
            stored rewards. Resume rules as ``init_from``.
        checkpoint_freq: Environment steps between checkpoints.
        eval_freq: Environment steps between success-rate evaluations.
        eval_episodes: Held-out subgoals per evaluation.
        snapshots: Keep the policy of every evaluation in ``out_dir/snapshots/`` (~4 MB each for the ant).
        progress_bar: Show SB3's progress bar.
        extra_callbacks: More SB3 callbacks to run.

    Raises:
        antmaze_hirl.sb3_ext.checkpoint.CheckpointError: On a missing, corrupt or mismatched checkpoint.
        FileExistsError: If a fresh run (``resume=False``) would overwrite a run in ``out_dir``.
        FileNotFoundError: If there is no file at ``init_from``.
        ValueError: On a negative ``total_timesteps``, a frequency or episode count below 1, a ``config`` for
            another algorithm, a fresh run whose ``config`` sets a warm-start option without ``init_from``, or an
            ``init_from`` that :func:`warm_start_parameters` refuses (unknown name, damaged zip, another
            algorithm, an ensemble, another body) or whose networks differ from ``config``'s.

    """
    if total_timesteps < 0:
        raise ValueError(f"total_timesteps must be >= 0, got {total_timesteps}")
    config = config if config is not None else load_config(body, algo=algo)
    _check_config_algo(config, algo)
    algorithm = training_class(algo, config)
    out_dir = Path(out_dir)
    checkpoint_dir = out_dir / "checkpoints"
    identity = {"body": body, "algo": algo, "seed": seed, "config": config.to_dict()}
    starts = {"init_from": init_from, "init_buffer": init_buffer}
    run_state = {**identity, **{key: None if path is None else str(path) for key, path in starts.items()}}
    if resume:
        given = {key: run_state[key] for key, path in starts.items() if path is not None}
        folder, state = latest_checkpoint(checkpoint_dir, expected={**identity, **given})
        for key in starts:  # later checkpoints keep where the run started from
            run_state[key] = state.get(key)
        # The config matched the checkpoint's, so this is the class (and warm-start options) the run began with.
        model = algorithm.load(folder / "model.zip", env=make_reach_env(body, config))
        model.load_replay_buffer(folder / "replay_buffer.pkl")
    else:
        if init_from is None and warm_start_kwargs(config):
            raise ValueError(
                "warmup_actions 'policy' and actor_frozen_steps > 0 fine-tune a warm start: "
                "give init_from (--init-from)"
            )
        if (checkpoint_dir / "latest.json").exists():
            raise FileExistsError(
                f"{checkpoint_dir} already holds a run; pass resume=True (--resume) or another out dir"
            )
        # On resume init_from is only the run's provenance, checked against the checkpoint; here it is read.
        parameters = None if init_from is None else warm_start_parameters(body, algo, init_from)
        model = make_model(body, algo, config, seed=seed, tensorboard_log=str(out_dir / "tb"))
        if parameters is not None:
            try:
                model.set_parameters(parameters, exact_match=True, device=model.device)
            except (RuntimeError, ValueError) as error:  # torch's size mismatch, an optimiser of other groups
                raise ValueError(
                    f"--init-from {init_from} holds networks that differ from this config's: "
                    f"{str(error).splitlines()[0]}"
                ) from error
        if init_buffer is not None:
            load_warm_buffer(model, init_buffer)
    # The callbacks check their frequencies and episode counts here, before any training step.
    callbacks: list[BaseCallback] = [
        RunCheckpointCallback(checkpoint_dir, checkpoint_freq, run_state),
        SuccessRateCallback(
            # The training env's settings (observation size, horizon, ...) on a simulator of its own; its
            # seeded resets never chain, so every held-out subgoal starts from rest, as in eval-low.
            ReachEnv(body, **config.env_kwargs),
            eval_freq=eval_freq,
            episodes=eval_episodes,
            csv_path=out_dir / "learning_curve.csv",
            snapshot_dir=out_dir / "snapshots" if snapshots else None,
        ),
        *(extra_callbacks or []),
    ]
    remaining = total_timesteps - model.num_timesteps
    if remaining > 0:
        model.learn(remaining, callback=callbacks, reset_num_timesteps=False, progress_bar=progress_bar)
    save_policy(model, out_dir / "policy.zip")
    return model


def warm_start_parameters(body: str, algo: str, init_from: str | Path) -> dict[str, dict[str, Any]]:
    """The weights and optimiser states (SB3's ``get_parameters``) that ``init_from`` gives a new ``algo`` model.

    ``init_from`` is a zip path or a low-level name of :data:`~antmaze_hirl.sb3_ext.loading.LOW_LEVEL_NAMES`.
    Everything is checked before a model is built, so that a bad warm start is one error and no training.

    Raises:
        FileNotFoundError: If there is no file at ``init_from``.
        ValueError: If ``init_from`` is an unknown name, not an SB3 zip or damaged, saved by another algorithm
            (a TD3 actor cannot initialise SAC's Gaussian one), an action ensemble (its actor has one head per
            member), or trained for another body; each names ``init_from``.
    """
    path = low_level_path(body, init_from)
    if not path.is_file():
        raise FileNotFoundError(f"--init-from {init_from}: no such file")
    source = algorithm_of(path)
    if not issubclass(algo_class(algo), source):
        raise ValueError(
            f"--init-from {init_from} holds a {source.__name__} policy; --algo {algo} cannot start from it"
        )
    if issubclass(policy_class_of(path), EnsemblePolicy):
        raise ValueError(f"--init-from {init_from} is an action ensemble; start from one of its member zips")
    return load_low_level(body, path).get_parameters()


def load_warm_buffer(model: OffPolicyAlgorithm, path: str | Path) -> None:
    """Gives ``model`` the HER replay buffer pickled at ``path`` (another run's checkpoint), bound to its env.

    Raises:
        FileNotFoundError: If ``path`` is not a file.
        ValueError: If the buffer is not a ``HerReplayBuffer``, or its observation or action shapes differ
            from the model's.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"--init-buffer {path} is not a file")
    expected = model.replay_buffer
    model.load_replay_buffer(path, truncate_last_traj=True)  # the other run's last episode ends here
    loaded = model.replay_buffer
    if not isinstance(loaded, HerReplayBuffer):
        model.replay_buffer = expected
        raise ValueError(f"--init-buffer {path} holds a {type(loaded).__name__}, not a HerReplayBuffer")
    shapes = {key: space.shape for key, space in expected.observation_space.spaces.items()}
    found = {key: space.shape for key, space in loaded.observation_space.spaces.items()}
    if found != shapes or loaded.action_space.shape != expected.action_space.shape:
        model.replay_buffer = expected
        raise ValueError(
            f"--init-buffer {path} holds observations {found} and actions {loaded.action_space.shape}; "
            f"this run needs {shapes} and {expected.action_space.shape}"
        )


def set_torch_threads(threads: int) -> None:
    """Limits torch's CPU threads (on 2 cores, 1 thread leaves one for the simulator or other work)."""
    torch.set_num_threads(threads)


__all__ = [
    "algo_class",
    "load_warm_buffer",
    "make_model",
    "make_reach_env",
    "set_torch_threads",
    "train_low_level",
    "training_class",
    "warm_start_kwargs",
    "warm_start_parameters",
]
