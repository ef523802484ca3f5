"""Crash-safe checkpoints of an SB3 off-policy run: model, replay buffer and run state.

Each checkpoint is a complete directory ``ckpt-<steps>/``; a ``latest.json`` pointer, replaced
atomically (temp file + rename) only once the directory is complete, names the one to resume. An
interrupted save therefore leaves the previous checkpoint intact.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.atomic_io import atomic_write_text

POINTER = "latest.json"
MODEL_FILE = "model.zip"
BUFFER_FILE = "replay_buffer.pkl"
STATE_FILE = "state.json"


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
    for name in (MODEL_FILE, BUFFER_FILE, STATE_FILE):
        _fsync(staging / name)
    final = directory / f"ckpt-{model.num_timesteps}"
    if final.exists():  # a second save at the same step count: never touch the folder the pointer may name
        final = directory / f"ckpt-{model.num_timesteps}-{staging.name.removeprefix('.staging-')}"
    os.replace(staging, final)
    _fsync(directory)
    atomic_write_text(directory / POINTER, json.dumps({"checkpoint": final.name}))
    # Everything else is superseded: the previous checkpoint and what crashed saves left behind (a staging
    # folder, or a checkpoint renamed into place before its pointer moved), ~0.5 GB each for the ant.
    for leftover in (*directory.glob("ckpt-*"), *directory.glob(".staging-*")):
        if leftover != final and leftover.is_dir():
            shutil.rmtree(leftover)
    return final


def _fsync(path: Path) -> None:
    # Durable before the pointer moves: a power cut must not leave the pointer naming unwritten files.
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


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


class CheckpointCallback(BaseCallback):
    """Saves a :func:`save_checkpoint` every ``save_freq`` environment steps and at the end of training.

    Saves fall at the end of a rollout (every ``train_freq`` steps for SB3's off-policy algorithms), so the
    checkpoint's replay buffer holds exactly its step count of transitions.

    Args:
        directory: Checkpoint folder.
        save_freq: Environment steps between checkpoints; an interrupted run loses at most this many.
        run_state: Identity of the run (body, algo, seed, config), checked on resume.

    """

    def __init__(self, directory: str | Path, save_freq: int, run_state: dict[str, Any], verbose: int = 0) -> None:
        super().__init__(verbose)
        if save_freq < 1:
            raise ValueError(f"save_freq must be >= 1, got {save_freq}")
        self.directory = Path(directory)
        self.save_freq = save_freq
        self.run_state = run_state
        self._last_saved = 0

    def _init_callback(self) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        self._last_saved = self.model.num_timesteps

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        # Not in _on_step: SB3 calls that before it stores the step's transition, so a checkpoint saved
        # there would hold one transition fewer than its step count. At a rollout's end both agree.
        if self.model.num_timesteps - self._last_saved >= self.save_freq:
            self._save()

    def _on_training_end(self) -> None:
        if self.model.num_timesteps != self._last_saved:
            self._save()

    def _save(self) -> None:
        folder = save_checkpoint(self.model, self.directory, self.run_state)
        self._last_saved = self.model.num_timesteps
        if self.verbose:
            print(f"checkpoint saved: {folder}")
