"""Low-level training with SB3's own TD3/DDPG and ``HerReplayBuffer``, plus checkpoints and evaluation."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import DDPG, TD3, HerReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.action_penalty import ActionPenaltyPolicy
from antmaze_hirl.sb3_ext.checkpoint import RunCheckpointCallback, latest_checkpoint
from antmaze_hirl.sb3_ext.config import ALGOS, LowLevelConfig, load_config
from antmaze_hirl.sb3_ext.evaluation import SuccessRateCallback
from antmaze_hirl.sb3_ext.extractors import RelativeGoalExtractor
from antmaze_hirl.sb3_ext.loading import save_policy

ALGO_CLASSES: dict[str, type[OffPolicyAlgorithm]] = {"td3": TD3, "ddpg": DDPG}


def algo_class(algo: str) -> type[OffPolicyAlgorithm]:
    """SB3 class for ``"td3"`` or ``"ddpg"``.

    Raises:
        ValueError: For any other name.

    """
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
    return kwargs


def make_model(
    body: str, algo: str, config: LowLevelConfig, *, seed: int, tensorboard_log: str | None = None
) -> OffPolicyAlgorithm:
    """A fresh SB3 TD3/DDPG with ``HerReplayBuffer`` on the reach env, configured by ``config``."""
    env = make_reach_env(body, config)
    n_actions = env.action_space.shape[0]
    return algo_class(algo)(
        ActionPenaltyPolicy if config.action_l2 > 0 else "MultiInputPolicy",
        env,
        learning_rate=config.learning_rate,
        buffer_size=config.buffer_size,
        batch_size=config.batch_size,
        gamma=config.gamma,
        tau=config.tau,
        learning_starts=config.learning_starts,
        train_freq=config.train_freq,
        gradient_steps=config.gradient_steps,
        action_noise=NormalActionNoise(np.zeros(n_actions), config.action_noise_std * np.ones(n_actions)),
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={
            "n_sampled_goal": config.n_sampled_goal,
            "goal_selection_strategy": "future",
            # HER recomputes relabelled rewards from the stored infos; without a copy it passes empty
            # dicts and a flip penalty would vanish from 80% of the samples. Copying costs time, so only then.
            "copy_info_dict": config.env_kwargs.get("flip_penalty", 0) > 0,
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

    Args:
        body: ``"ant"`` or ``"point"``.
        algo: ``"td3"`` or ``"ddpg"``.
        total_timesteps: Target step count, counting steps done before a resume.
        out_dir: Run folder.
        seed: Seed of the model and envs.
        resume: Continue from the latest checkpoint in ``out_dir`` (error if there is none or it was
            made with another body, algo, seed or config).
        config: Hyperparameters; default :func:`load_config` for ``body``.
        init_from: Warm start: a TD3/DDPG ``.zip`` with the same networks whose weights and optimiser
            states the new model starts from (its replay buffer starts empty). On resume it may be left
            out (the checkpoint holds the weights); if given, it must be the one the run started from.
        checkpoint_freq: Environment steps between checkpoints.
        eval_freq: Environment steps between success-rate evaluations.
        eval_episodes: Held-out subgoals per evaluation.
        snapshots: Keep the policy of every evaluation in ``out_dir/snapshots/`` (~4 MB each for the ant).
        progress_bar: Show SB3's progress bar.
        extra_callbacks: More SB3 callbacks to run.

    Raises:
        antmaze_hirl.sb3_ext.checkpoint.CheckpointError: On a missing, corrupt or mismatched checkpoint.
        FileExistsError: If a fresh run (``resume=False``) would overwrite a run in ``out_dir``.
        ValueError: On a negative ``total_timesteps``, or a frequency or episode count below 1.

    """
    if total_timesteps < 0:
        raise ValueError(f"total_timesteps must be >= 0, got {total_timesteps}")
    config = config if config is not None else load_config(body)
    algo_class(algo)
    out_dir = Path(out_dir)
    checkpoint_dir = out_dir / "checkpoints"
    identity = {"body": body, "algo": algo, "seed": seed, "config": config.to_dict()}
    run_state = {**identity, "init_from": None if init_from is None else str(init_from)}
    if resume:
        folder, state = latest_checkpoint(checkpoint_dir, expected=run_state if init_from is not None else identity)
        run_state["init_from"] = state.get("init_from")  # later checkpoints keep where the run started from
        model = algo_class(algo).load(folder / "model.zip", env=make_reach_env(body, config))
        model.load_replay_buffer(folder / "replay_buffer.pkl")
    else:
        if (checkpoint_dir / "latest.json").exists():
            raise FileExistsError(
                f"{checkpoint_dir} already holds a run; pass resume=True (--resume) or another out dir"
            )
        model = make_model(body, algo, config, seed=seed, tensorboard_log=str(out_dir / "tb"))
        if init_from is not None:
            model.set_parameters(str(init_from), exact_match=True, device=model.device)
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


def set_torch_threads(threads: int) -> None:
    """Limits torch's CPU threads (on 2 cores, 1 thread leaves one for the simulator or other work)."""
    torch.set_num_threads(threads)


__all__ = ["algo_class", "make_model", "make_reach_env", "set_torch_threads", "train_low_level"]
