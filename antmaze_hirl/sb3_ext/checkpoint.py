"""Crash-safe checkpoints of an SB3 off-policy run: model, replay buffer and run state.

Each checkpoint is a complete directory ``ckpt-<steps>/``; a ``latest.json`` pointer, replaced
atomically (temp file + rename) only once the directory is complete, names the one to resume. An
interrupted save therefore leaves the previous checkpoint intact.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.atomic_io import atomic_write_text, fsync_path

POINTER = "latest.json"
MODEL_FILE = "model.zip"
BUFFER_FILE = "replay_buffer.pkl"
STATE_FILE = "state.json"
_SAVED_NAME = re.compile(r"ckpt-\d+(-\w+)?|\.staging-\w+")  # what save_checkpoint names its folders


class CheckpointError(RuntimeError):
    """A checkpoint is missing, truncated, or belongs to another run."""


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def save_checkpoint(model: OffPolicyAlgorithm, directory: str | Path, run_state: dict[str, Any]) -> Path:
    """Saves model, replay buffer and ``run_state`` as the new latest checkpoint of ``directory``.

    Returns:
        The checkpoint's own folder.

    """
    directory = Path(directory)
    staging = Path(tempfile.mkdtemp(dir=directory, prefix=".staging-"))
    model.save(staging / MODEL_FILE)
    model.save_replay_buffer(staging / BUFFER_FILE)
    state = {
        **run_state,
        "num_timesteps": model.num_timesteps,
        "buffer_size": model.replay_buffer.size() if model.replay_buffer is not None else 0,
        "sha256": {name: _sha256(staging / name) for name in (MODEL_FILE, BUFFER_FILE)},
    }
    (staging / STATE_FILE).write_text(json.dumps(state, indent=2))
    for name in (MODEL_FILE, BUFFER_FILE, STATE_FILE):  # durable before the pointer can name them
        fsync_path(staging / name)
    final = directory / f"ckpt-{model.num_timesteps}"
    if final.exists():  # a second save at the same step count: never touch the folder the pointer may name
        final = directory / f"ckpt-{model.num_timesteps}-{staging.name.removeprefix('.staging-')}"
    os.replace(staging, final)
    fsync_path(directory)
    atomic_write_text(directory / POINTER, json.dumps({"checkpoint": final.name}))
    # Everything else is superseded: the previous checkpoint and what crashed saves left behind (a staging
    # folder, or a checkpoint renamed into place before its pointer moved), ~0.5 GB each for the ant.
    for leftover in directory.iterdir():
        if leftover != final and leftover.is_dir() and _SAVED_NAME.fullmatch(leftover.name):
            shutil.rmtree(leftover)
    return final


def _pointed_dir(directory: Path) -> Path | None:
    pointer = directory / POINTER
    if not pointer.exists():
        return None
    try:
        return directory / json.loads(pointer.read_text())["checkpoint"]
    except (json.JSONDecodeError, KeyError, TypeError) as error:
        raise CheckpointError(f"checkpoint pointer {pointer} is corrupt: {error}") from error


def latest_checkpoint(directory: str | Path, expected: dict[str, Any] | None = None) -> tuple[Path, dict[str, Any]]:
    """The latest complete checkpoint of ``directory`` and its verified run state.

    Args:
        directory: Where :func:`save_checkpoint` wrote.
        expected: Run-state entries the checkpoint must match (body, algo, config, ...).

    Raises:
        CheckpointError: If there is no checkpoint, a file is missing or truncated (hash mismatch),
            or a run-state entry differs from ``expected`` (naming the key and both values).

    """
    directory = Path(directory)
    folder = _pointed_dir(directory)
    if folder is None:
        raise CheckpointError(f"no checkpoint to resume in {directory} (missing {POINTER})")
    state_path = folder / STATE_FILE
    try:
        state = json.loads(state_path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise CheckpointError(f"checkpoint state {state_path} is unreadable: {error}") from error
    digests = state.get("sha256") if isinstance(state, dict) else None
    if not isinstance(digests, dict) or set(digests) != {MODEL_FILE, BUFFER_FILE}:
        raise CheckpointError(
            f"checkpoint state {state_path} has no sha256 of {MODEL_FILE} and {BUFFER_FILE}: not a complete checkpoint"
        )
    for name, digest in digests.items():
        path = folder / name
        if not path.exists() or _sha256(path) != digest:
            raise CheckpointError(f"checkpoint file {path} is missing or corrupt (sha256 mismatch)")
    for key, value in (expected or {}).items():
        if state.get(key) != value:
            raise CheckpointError(
                f"checkpoint in {folder} was made with {key}={state.get(key)!r}, this run has {value!r}"
            )
    return folder, state


class RunCheckpointCallback(BaseCallback):
    """Saves a :func:`save_checkpoint` every ``save_freq`` environment steps and at the end of training.

    Saves fall between rollouts (every ``train_freq`` steps for SB3's off-policy algorithms), after the
    gradient updates of the last one, so a checkpoint's replay buffer holds exactly its step count of
    transitions and its weights have had every update of those steps.

    Named apart from SB3's ``CheckpointCallback(save_freq, save_path, ...)``, which writes model files in
    place and keeps no replay buffer or run identity.

    Args:
        directory: Checkpoint folder.
        save_freq: Environment steps between checkpoints; an interrupted run loses at most this many plus
            one rollout.
        run_state: Identity of the run (body, algo, seed, config), checked on resume.

    """

    def __init__(self, directory: str | Path, save_freq: int, run_state: dict[str, Any], verbose: int = 0) -> None:
        super().__init__(verbose)
        if save_freq < 1:
            raise ValueError(f"save_freq must be >= 1, got {save_freq}")
        self.directory = Path(directory)
        self.save_freq = save_freq
        self.run_state = run_state
        self._last_saved = (0, 0)

    def _init_callback(self) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        self._last_saved = self._progress()

    def _progress(self) -> tuple[int, int]:
        return self.model.num_timesteps, self.model._n_updates

    def _on_step(self) -> bool:
        return True

    def _on_rollout_start(self) -> None:
        # Not in _on_step, which SB3 calls before storing the step's transition, nor in _on_rollout_end,
        # which comes before the rollout's gradient updates: when the next rollout starts, both are done.
        if self.model.num_timesteps - self._last_saved[0] >= self.save_freq:
            self._save()

    def _on_training_end(self) -> None:
        if self._progress() != self._last_saved:  # the last rollout's updates come after its last save
            self._save()

    def _save(self) -> None:
        folder = save_checkpoint(self.model, self.directory, self.run_state)
        self._last_saved = self._progress()
        if self.verbose:
            print(f"checkpoint saved: {folder}")
