"""How a settings file written by an older version reads today: the one adapter for old results and study folders.

The library's defaults are the current protocol (:class:`~antmaze_hirl.experiments.config.ExperimentConfig`);
files written before then differ in two ways, and only here:

* **Old keys.** Up to 0.2.0 a results folder's ``config.json`` (the committed ``results/paper_experiment`` and
  ``results/protocol2`` folders, and the trials packed in ``results/protocol2/runs/*.tar.gz``) and a study's
  ``settings.json`` held the oracle's reach as ``expert_max_distance`` (:data:`OLD_KEYS`).
* **Missing settings.** A ``config.json`` written before a setting existed was made with the value the code had
  then. For the settings whose default has changed since (:data:`SETTINGS_BEFORE_PROTOCOL_2`) that is not
  today's default: read as today's, a protocol-1 folder would claim to be protocol 2.
* **A study's old record keys.** Up to 0.2.0 a study's ``clicks.jsonl``, ``demonstrations.npz`` and pickled
  ``DemonstrationLog`` named both the label index and the high-level step ``step`` (:data:`OLD_STUDY_KEYS`).

Why hand-written: the files are this project's own format, and no library reads them.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.experiments.config import protocol_evaluation_envs

OLD_KEYS: dict[str, str] = {"expert_max_distance": "subgoal_reach_m"}
"""Each key an older version wrote, with the setting's name today."""

SETTINGS_BEFORE_PROTOCOL_2: dict[str, Any] = {
    "protocol": 1,
    "held_out_layouts": False,
    "evaluation_envs": protocol_evaluation_envs(1),
}
"""The value of each setting whose default changed when the current protocol became the default, as the code
had it before the setting was recorded: a ``config.json`` that lacks one of these was made with this value
(the committed protocol-1 folders lack ``protocol`` and ``evaluation_envs``). A study's settings need none of
this: its ``held_out_layouts`` default is still ``False``."""


def current_settings(recorded: Mapping[str, Any], source: str | Path) -> dict[str, Any]:
    """A settings file's object (``config.json``, a summary's ``config``, a study's ``settings.json``) as today's.

    Each old key of :data:`OLD_KEYS` becomes its setting's name, in its place; a file holding one setting under
    both keys with one value reads as holding it once. Keys are otherwise kept as they are (``low_level`` too).

    Raises:
        ValueError: One line naming ``source``: not a JSON object, or a setting under both keys with two values.
    """
    if not isinstance(recorded, Mapping):
        raise ValueError(f"{source} holds a {type(recorded).__name__}, not an object of settings")
    for old_key, key in OLD_KEYS.items():
        if key in recorded and old_key in recorded and recorded[key] != recorded[old_key]:
            raise ValueError(
                f"{source}: {key!r} and its old name {old_key!r} hold different values "
                f"({recorded[key]!r} against {recorded[old_key]!r})"
            )
    settings: dict[str, Any] = {}
    for key, value in recorded.items():
        settings.setdefault(OLD_KEYS.get(key, key), value)
    return settings


def experiment_settings(recorded: Mapping[str, Any], source: str | Path) -> dict[str, Any]:
    """A results folder's ``config.json`` object (or a summary's ``config``) as today's settings.

    :func:`current_settings`, and every setting of :data:`SETTINGS_BEFORE_PROTOCOL_2` the file lacks at the
    value it was made with. Other settings it lacks read at today's defaults, which have not changed.

    Raises:
        ValueError: As :func:`current_settings`.
    """
    settings = current_settings(recorded, source)
    return {**settings, **{key: value for key, value in SETTINGS_BEFORE_PROTOCOL_2.items() if key not in settings}}


OLD_STUDY_KEYS: dict[str, str] = {"label_index": "step", "high_level_step": "step"}
"""Each key of a study's records with the name files up to 0.2.0 wrote it under: ``step`` held the label index in
``clicks.jsonl`` and the high-level step in ``demonstrations.npz`` (two concepts under one name, so the map runs
from today's name)."""


def current_study_record(record: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
    """A study record (a JSON line, an ``.npz``'s arrays, a pickled state) with ``key`` under today's name.

    ``key`` (one of :data:`OLD_STUDY_KEYS`) takes the value under either name, and the old name is dropped. A
    record with both names is read if they hold the same value (compared as arrays: ``.npz`` arrays and JSON
    values alike).

    Raises:
        ValueError: If ``record`` has neither name, or both with different values (names ``where``, the key
            and the first values that differ).
    """
    old_key = OLD_STUDY_KEYS[key]
    if key not in record and old_key not in record:
        raise ValueError(f"{where}: no {key!r} (nor its old name {old_key!r})")
    if key in record and old_key in record:
        new, old = np.asarray(record[key]), np.asarray(record[old_key])
        if not np.array_equal(new, old):
            raise ValueError(
                f"{where}: {key!r} and its old name {old_key!r} hold different values ({_difference(new, old)})"
            )
    value = record[key] if key in record else record[old_key]
    current = {name: item for name, item in record.items() if name != old_key}
    current[key] = value
    return current


def _difference(new: np.ndarray, old: np.ndarray) -> str:
    """Where two values differ, in a few words: the values, their shapes, or the first index and its values."""
    if new.ndim == 0 and old.ndim == 0:
        return f"{new.item()!r} against {old.item()!r}"
    if new.shape != old.shape:
        return f"shapes {new.shape} against {old.shape}"
    index = int(np.flatnonzero(new.ravel() != old.ravel())[0])
    return f"at index {index}: {new.ravel()[index].item()!r} against {old.ravel()[index].item()!r}"
