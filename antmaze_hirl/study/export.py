"""Exports the study's high-level demonstrations as a Minari dataset.

The server saves each trial's demonstrations as
``DIR/participants/<pid>/trial<k>/demonstrations.npz`` with the arrays (``N`` high-level steps of
``E`` episodes):

- ``images`` ``(N, 3, H, W)`` uint8 and ``states`` ``(N, D)`` float32: what the learner saw;
- ``executed`` ``(N, 2)`` float32: the subgoal the env executed (Minari's action);
- ``labels`` ``(N, 2)`` float32: the participant's click, NaN where they were not asked;
- ``labelled`` ``(N,)`` bool: whether they were asked;
- ``episode`` ``(N,)`` and ``high_level_step`` ``(N,)`` int: each step's episode (``0 .. E-1``) and position
  in it (files written up to 0.2.0 name the latter ``step``; they load the same);
- ``success`` ``(E,)`` bool: whether each episode reached its goal;
- ``terminal_success`` ``(N,)`` bool: the reward at that step.

Minari is an optional extra (``pip install -e .[minari]``), imported only here.
"""

from __future__ import annotations

import os
import re
import shutil
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.profiles import maze_env_id
from antmaze_hirl.experiments.old_folders import current_study_record
from antmaze_hirl.study.data import participant_dir
from antmaze_hirl.study.plan import load_plan

DATASET_ID_PATTERN = re.compile(r"[\w-]+(/[\w-]+)*/[\w.-]+?-v(0|[1-9][0-9]*)", re.ASCII)
"""Minari ids with a namespace and a version: ``namespace/name-v0``."""

_ARRAYS = {
    # name: (allowed dtype kinds, what they are called, trailing shape or None for any, one per step?)
    "images": ("u", "uint8", None, True),
    "states": ("f", "float", None, True),
    "executed": ("f", "float", (2,), True),
    "labels": ("f", "float", (2,), True),
    "labelled": ("b", "bool", (), True),
    "episode": ("iu", "int", (), True),
    "high_level_step": ("iu", "int", (), True),
    "success": ("b", "bool", (), False),
    "terminal_success": ("b", "bool", (), True),
}


class MinariMissingError(ImportError):
    """Minari (the optional ``minari`` extra) is not installed."""


def check_dataset_id(dataset_id: str) -> str:
    """Returns ``dataset_id`` if it has Minari's ``namespace/name-v<version>`` form.

    Raises:
        ValueError: Otherwise, naming the id.
    """
    if not isinstance(dataset_id, str) or not DATASET_ID_PATTERN.fullmatch(dataset_id):
        raise ValueError(
            f"dataset id {dataset_id!r} must have the form 'namespace/name-v0' (e.g. 'antmaze-hirl/study-v0')"
        )
    return dataset_id


def load_demonstrations(path: str | Path) -> dict[str, np.ndarray]:
    """Reads and checks one trial's ``demonstrations.npz`` (format: module docstring).

    Returns:
        The arrays by name; the high-level steps under ``high_level_step`` whichever name the file used.

    Raises:
        ValueError: If an array is missing, has the wrong dtype or shape, or the episode indices
            do not fit ``success`` (the message names the file).
    """
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable .npz file: {error}") from None
    arrays = current_study_record(arrays, "high_level_step", str(path))
    missing = sorted(set(_ARRAYS) - set(arrays))
    if missing:
        raise ValueError(f"{path} lacks the arrays {missing}")
    if arrays["episode"].ndim != 1:
        raise ValueError(f"{path}: episode has shape {arrays['episode'].shape}, expected one index per step (N,)")
    steps = len(arrays["episode"])
    for name, (kinds, dtype, trailing, per_step) in _ARRAYS.items():
        array = arrays[name]
        if array.dtype.kind not in kinds or (name == "images" and array.dtype != np.uint8):
            raise ValueError(f"{path}: {name} has dtype {array.dtype}, expected {dtype}")
        wrong_length = array.ndim == 0 or (per_step and len(array) != steps)
        if wrong_length or (trailing is not None and array.shape[1:] != trailing):
            raise ValueError(f"{path}: {name} has shape {array.shape}, which does not fit {steps} steps")
    if arrays["images"].ndim != 4 or arrays["images"].shape[1] != 3 or arrays["states"].ndim != 2:
        raise ValueError(
            f"{path}: images {arrays['images'].shape} / states {arrays['states'].shape} are not (N,3,H,W) / (N,D)"
        )
    outside = arrays["episode"][(arrays["episode"] < 0) | (arrays["episode"] >= len(arrays["success"]))]
    if outside.size:
        raise ValueError(f"{path}: episode index {int(outside[0])} outside success's {len(arrays['success'])} episodes")
    labelled_steps = np.flatnonzero(arrays["labelled"])
    unlabelled = labelled_steps[~np.isfinite(arrays["labels"][labelled_steps]).all(axis=1)]
    if unlabelled.size:
        step = int(unlabelled[0])
        raise ValueError(f"{path}: step {step} is marked labelled but its label is {arrays['labels'][step].tolist()}")
    pairs = np.stack([arrays["episode"], arrays["high_level_step"]], axis=1)
    if len(np.unique(pairs, axis=0)) != steps:
        raise ValueError(f"{path}: an (episode, high_level_step) pair repeats")
    return arrays


def _episode_buffers(arrays: dict[str, np.ndarray], participant: int, trial: int) -> Iterator[dict[str, Any]]:
    """One Minari episode per episode of the trial, in episode order."""
    for episode in np.unique(arrays["episode"]):
        rows = np.flatnonzero(arrays["episode"] == episode)
        rows = rows[np.argsort(arrays["high_level_step"][rows], kind="stable")]
        # Minari wants one observation more than actions; the state after the final subgoal is not
        # recorded, so the last observation is repeated (its info marks it unlabelled).
        with_last = np.append(rows, rows[-1])
        steps = len(rows)
        success = bool(arrays["success"][episode])
        end = np.zeros(steps, dtype=bool)
        end[-1] = True
        yield {
            "observations": {
                "image": arrays["images"][with_last],
                "state": arrays["states"][with_last].astype(np.float32),
            },
            "actions": arrays["executed"][rows].astype(np.float32),
            "rewards": arrays["terminal_success"][rows].astype(np.float64),
            "terminations": end & success,
            "truncations": end & (not success),
            # Info t belongs to observation t (Minari's reset info comes with the first one).
            "infos": {
                "label": np.vstack([arrays["labels"][rows], np.full((1, 2), np.nan)]).astype(np.float32),
                "labelled": np.append(arrays["labelled"][rows], False),
                "participant": np.full(steps + 1, participant, dtype=np.int64),
                "trial": np.full(steps + 1, trial, dtype=np.int64),
                "episode": np.full(steps + 1, int(episode), dtype=np.int64),
            },
        }


@contextmanager
def _datasets_path(data_path: str | Path | None) -> Iterator[None]:
    """Points Minari at ``data_path`` for the duration (Minari reads only the environment variable)."""
    if data_path is None:
        yield
        return
    previous = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(data_path)
    try:
        yield
    finally:
        if previous is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = previous


def study_env_spec(study_dir: str | Path, body: str) -> Any:
    """The registered high-level env of the study's body, with the study's maze size, as a Gymnasium ``EnvSpec``.

    What ``MinariDataset.recover_environment()`` rebuilds: the body's maze family (with the study's
    ``maze_size`` when ``settings.json`` is there) and its shipped low level. A study with held-out
    layouts drew its mazes from one part of that family; the spec gives the whole family.
    """
    import dataclasses

    import gymnasium as gym

    from antmaze_hirl.study.settings import SETTINGS_FILE, load_settings

    spec = gym.spec(maze_env_id(body))
    if (Path(study_dir) / SETTINGS_FILE).exists():
        spec = dataclasses.replace(spec, kwargs={**spec.kwargs, "maze_size": load_settings(study_dir).maze_size})
    return spec


MINARI_PROVENANCE = ("author", "author_email", "code_permalink")
"""Minari's metadata that only the person exporting knows; each one left out is named in one warning."""


def export_minari(
    study_dir: str | Path,
    dataset_id: str,
    *,
    include_practice: bool = False,
    data_path: str | Path | None = None,
    author: str | None = None,
    author_email: str | None = None,
    code_permalink: str | None = None,
) -> Path:
    """Writes every saved trial's demonstrations as one Minari dataset.

    Each episode of each trial becomes a Minari episode: observations ``{"image", "state"}``, actions
    the executed subgoals, rewards the per-step success, and infos ``label`` (the participant's
    click, NaN where not asked), ``labelled``, ``participant`` (the number of ``Pxx``), ``trial`` and
    ``episode``. Trials without a ``demonstrations.npz`` (not reached yet) are skipped.

    Minari stores datasets under ``$MINARI_DATASETS_PATH`` (default ``~/.minari/datasets``); pass
    ``data_path`` to use another folder for this call (it sets that variable meanwhile, so do not
    export from two threads at once). Load the result with ``minari.load_dataset(dataset_id)`` under
    the same path.

    Args:
        study_dir: The study folder.
        dataset_id: Minari id, ``namespace/name-v0``.
        include_practice: Also export the practice trials.
        data_path: Minari's datasets folder for this export (default: Minari's own).
        author: The dataset's author, recorded in its metadata.
        author_email: The author's contact.
        code_permalink: A link to the versioned code that collected it.

    Those three are the experimenter's to give: any left out is named in one warning (Minari's own warns
    once for each, and for the evaluation env, which is set here to the study's env).

    Returns:
        The dataset's folder.

    Raises:
        ValueError: On a malformed id, an id already taken, a study without demonstrations, or a
            bad ``demonstrations.npz`` (the message names it).
        MinariMissingError: If Minari is not installed.
    """
    check_dataset_id(dataset_id)
    try:
        import minari
        from minari.data_collector import EpisodeBuffer
        from minari.storage import get_dataset_path
    except ImportError:
        raise MinariMissingError("Minari export needs the extra: pip install -e .[minari]") from None
    from gymnasium import spaces

    plan = load_plan(study_dir)
    buffers = []
    for number, participant in enumerate(plan.participants, start=1):
        for trial in participant.trials:
            path = participant_dir(study_dir, participant.id) / f"trial{trial.index}" / "demonstrations.npz"
            if (trial.practice and not include_practice) or not path.exists():
                continue
            buffers += list(_episode_buffers(load_demonstrations(path), number, trial.index))
    if not buffers:
        raise ValueError(f"no demonstrations to export under {Path(study_dir) / 'participants'}")
    shapes = {(b["observations"]["image"].shape[1:], b["observations"]["state"].shape[1:]) for b in buffers}
    if len(shapes) > 1:
        raise ValueError(f"trials differ in image/state shapes {sorted(shapes)}; one dataset needs one shape")
    ((image_shape, state_shape),) = shapes
    observation_space = spaces.Dict(
        {
            "image": spaces.Box(0, 255, image_shape, np.uint8),
            "state": spaces.Box(-np.inf, np.inf, state_shape, np.float32),
        }
    )
    env_spec = study_env_spec(study_dir, plan.body)
    with _datasets_path(data_path):
        target = get_dataset_path(dataset_id)
        if target.exists():
            raise ValueError(f"Minari dataset {dataset_id!r} already exists at {target}; pick a new name or version")
        provenance = {"author": author, "author_email": author_email, "code_permalink": code_permalink}
        try:
            with warnings.catch_warnings():
                # Minari warns once per missing field; the one warning below names them all with their options.
                warnings.filterwarnings("ignore", message=r"`(author|author_email|code_permalink)` is set to None")
                minari.create_dataset_from_buffers(
                    dataset_id,
                    [EpisodeBuffer(id=i, **buffer) for i, buffer in enumerate(buffers)],
                    observation_space=observation_space,
                    action_space=spaces.Box(-np.inf, np.inf, (2,), np.float32),
                    env=env_spec,  # so that dataset.recover_environment() builds the study's high-level env
                    eval_env=env_spec,  # held-out evaluation is the experiment's, not the dataset's: the same env
                    algorithm_name="antmaze_hirl user study (human high-level labels)",
                    description=f"High-level demonstrations of the {plan.body} maze user study; infos hold the labels.",
                    jpeg_encoding=False,  # the learner trains on exact pixels: store them losslessly
                    **provenance,
                )
        except BaseException:
            shutil.rmtree(target, ignore_errors=True)  # a half-written dataset would block a retry
            raise
    missing = [name for name in MINARI_PROVENANCE if provenance[name] is None]
    if missing:
        options = ", ".join(f"--{name.replace('_', '-')}" for name in missing)
        warnings.warn(f"Minari dataset {dataset_id} records no {', '.join(missing)} (give {options})", stacklevel=2)
    return target
