"""Reads what the study server wrote for each participant into tables checked against the plan.

The files (one folder per participant, ``DIR/participants/<pid>/``) are described in
:mod:`antmaze_hirl.study.analysis`. Missing folders and files mean a participant has not started
(or not reached) that part; a file that contradicts the plan or cannot be parsed is an error.
The logs carry a checksum per line (:mod:`antmaze_hirl.study.logs`): a torn last line is skipped with
a warning, any other damaged line is an error naming the file and line.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from antmaze_hirl.experiments.old_folders import current_study_record
from antmaze_hirl.experiments.runner import COLUMNS
from antmaze_hirl.study.logs import read_csv_rows, read_json_records
from antmaze_hirl.study.plan import StudyPlan, TrialPlan
from antmaze_hirl.study.questionnaire import ITEM_KEYS, validate_answers

EPISODE_COLUMNS: tuple[str, ...] = (
    "participant",
    "trial",
    "method",
    "label",
    "practice",
    "seed",
    # The trainer's own episode record (as the experiment's tables have it), then the human's timing.
    *(column for column in COLUMNS if column not in ("method", "seed")),
    "seconds_per_label",
    "time_on_task",
    "learner_updates",
)
"""Columns of ``episodes.csv``, in order. ``learner_updates``: how many learner updates the policy that played
the maze had had (with background updates, one fewer than the episodes before it: the learner lags a maze)."""

ADDED_EPISODE_COLUMNS: tuple[str, ...] = ("learner_updates",)
"""Trailing columns of :data:`EPISODE_COLUMNS` that files written before them lack (read as empty)."""


def read_episode_rows(path: str | Path) -> list[dict[str, str]]:
    """The rows of an ``episodes.csv`` as strings (:func:`~antmaze_hirl.study.logs.read_csv_rows`), old files too.

    Raises:
        DamagedLog: For a damaged line or a header of other columns (names the file and line).
    """
    return read_csv_rows(path, EPISODE_COLUMNS, ADDED_EPISODE_COLUMNS)


_BOOLEAN_COLUMNS = ("practice", "success")
_TEXT_COLUMNS = ("participant", "method", "label", "layout")
_OPTIONAL_COLUMNS = ("eval_success", "eval_attempts", "seconds_per_label", "eval_mazes", *ADDED_EPISODE_COLUMNS)
_NUMBER_COLUMNS = tuple(c for c in EPISODE_COLUMNS if c not in _BOOLEAN_COLUMNS + _TEXT_COLUMNS)


def participant_dir(study_dir: str | Path, participant: str) -> Path:
    """The folder of one participant's files."""
    return Path(study_dir) / "participants" / participant


def _trial(plan: StudyPlan, participant: str, index: object, where: str) -> TrialPlan:
    """The planned trial ``index`` of ``participant``; an error naming ``where`` if there is none."""
    for candidate in plan.participants:
        if candidate.id == participant:
            for trial in candidate.trials:
                if trial.index == index:
                    return trial
            raise ValueError(f"{where}: {participant} has no trial {index!r} in the plan")
    raise ValueError(f"{where}: participant {participant!r} is not in the plan")


def _check_matches_plan(
    plan: StudyPlan, participant: str, trial: object, method: object, label: object, where: str
) -> TrialPlan:
    planned = _trial(plan, participant, trial, where)
    if (method, label) != (planned.method, planned.label):
        raise ValueError(
            f"{where}: trial {trial} is {method!r} / {label!r} but the plan has {planned.method!r} / {planned.label!r}"
        )
    return planned


def load_episodes(study_dir: str | Path, plan: StudyPlan) -> pd.DataFrame:
    """All participants' ``episodes.csv`` rows (practice included), checked against the plan.

    Args:
        study_dir: The study folder.
        plan: Its plan.

    Returns:
        One row per finished episode with :data:`EPISODE_COLUMNS`; ``practice`` and ``success`` are
        bools, the ``eval_*`` columns NaN where the episode was not evaluated.

    Raises:
        ValueError: If a file has other columns, unparsable values, repeated episodes, or trials
            that contradict the plan (the message names the file).
    """
    frames = [_read_episodes(path, plan) for p in plan.participants if (path := _episodes_file(study_dir, p.id))]
    frames = [frame for frame in frames if not frame.empty]
    if not frames:
        return pd.DataFrame({column: pd.Series(dtype=object) for column in EPISODE_COLUMNS})
    return pd.concat(frames, ignore_index=True)


def _episodes_file(study_dir: str | Path, participant: str) -> Path | None:
    path = participant_dir(study_dir, participant) / "episodes.csv"
    return path if path.exists() else None


def _read_episodes(path: Path, plan: StudyPlan) -> pd.DataFrame:
    try:
        rows = read_episode_rows(path)
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"{path} is not a readable CSV: {' '.join(str(error).split())}") from None
    if not rows:
        return pd.DataFrame()  # created but nothing written yet
    frame = pd.DataFrame(rows, columns=list(EPISODE_COLUMNS), dtype=str)
    for column in _BOOLEAN_COLUMNS:
        bad = frame.loc[~frame[column].isin(["True", "False"]), column]
        if len(bad):
            raise ValueError(f"{path}: {column} must be True or False, got {bad.iloc[0]!r}")
        frame[column] = frame[column] == "True"
    for column in _NUMBER_COLUMNS:
        values = pd.to_numeric(frame[column], errors="coerce")
        # Empty cells may only be optional ones (eval_* between evaluations, no label in an episode).
        bad = frame.loc[values.isna() & ((frame[column] != "") | (column not in _OPTIONAL_COLUMNS)), column]
        if len(bad):
            raise ValueError(f"{path}: {column} must be a number, got {bad.iloc[0]!r}")
        frame[column] = values.astype(float)
    for column in ("trial", "episode"):
        fractional = frame.loc[frame[column] % 1 != 0, column]
        if len(fractional):
            raise ValueError(f"{path}: {column} must be a whole number, got {float(fractional.iloc[0])}")
    participant = path.parent.name
    for key, rows in frame.groupby(["participant", "trial", "method", "label", "practice"], sort=False):
        pid, trial, method, label, practice = key
        if pid != participant:
            raise ValueError(f"{path}: rows of participant {pid!r} in {participant}'s file")
        planned = _check_matches_plan(plan, pid, int(trial), method, label, str(path))
        if practice != planned.practice:
            raise ValueError(f"{path}: trial {int(trial)} has practice={practice} but the plan says {planned.practice}")
        outside = rows["episode"][(rows["episode"] < 0) | (rows["episode"] >= planned.episodes)]
        if len(outside):
            raise ValueError(f"{path}: trial {int(trial)} has episode {int(outside.iloc[0])} of {planned.episodes}")
        repeated = rows["episode"][rows["episode"].duplicated()]
        if len(repeated):
            raise ValueError(f"{path}: trial {int(trial)} has episode {int(repeated.iloc[0])} more than once")
    frame["trial"] = frame["trial"].astype(int)
    frame["episode"] = frame["episode"].astype(int)
    return frame


def finished_trials(episodes: pd.DataFrame, plan: StudyPlan) -> pd.DataFrame:
    """The rows of the trials whose every planned episode is present, sorted by episode."""
    planned = {(p.id, t.index): t.episodes for p in plan.participants for t in p.trials}
    keys = zip(episodes["participant"], episodes["trial"], strict=True)
    expected = pd.Series([planned[key] for key in keys], index=episodes.index, dtype=float)
    done = episodes.groupby(["participant", "trial"])["episode"].transform("size") == expected
    return episodes.loc[done.astype(bool)].sort_values(["participant", "trial", "episode"], ignore_index=True)


def load_answers(study_dir: str | Path, plan: StudyPlan) -> pd.DataFrame:
    """All participants' questionnaires, validated and checked against the plan.

    A trial answered twice keeps its last answer (a resubmission replaces the first).

    Args:
        study_dir: The study folder.
        plan: Its plan.

    Returns:
        One row per answered trial: ``participant, trial, method, label, practice``, one column per
        TLX item, ``comment``.

    Raises:
        ValueError: If a line is not JSON, fails :func:`validate_answers`, or contradicts the plan
            (the message names the file and line).
    """
    records = []
    for participant in plan.participants:
        path = participant_dir(study_dir, participant.id) / "answers.jsonl"
        if path.exists():
            records.extend(_read_answers(path, plan, participant.id))
    columns = ["participant", "trial", "method", "label", "practice", *ITEM_KEYS, "comment"]
    frame = pd.DataFrame(records, columns=columns)
    return frame.drop_duplicates(["participant", "trial"], keep="last", ignore_index=True)


def _read_answers(path: Path, plan: StudyPlan, participant: str) -> list[dict[str, object]]:
    records = []
    for number, entry in read_json_records(path):
        where = f"{path}:{number}"
        try:
            answers = validate_answers({key: entry[key] for key in ("ratings", "comment") if key in entry})
            if entry.get("participant") != participant:
                raise ValueError(f"participant {entry.get('participant')!r} in {participant}'s file")
            planned = _check_matches_plan(
                plan, participant, entry.get("trial"), entry.get("method"), entry.get("label"), where
            )
        except ValueError as error:
            message = str(error)
            raise ValueError(message if message.startswith(where) else f"{where}: {message}") from None
        records.append(
            {
                "participant": participant,
                "trial": planned.index,
                "method": planned.method,
                "label": planned.label,
                "practice": planned.practice,
                **answers.ratings,
                "comment": answers.comment,
            }
        )
    return records


CLICK_COLUMNS: tuple[str, ...] = (
    "participant",
    "trial",
    "episode",
    "label_index",
    "query",
    "time",
    "x",
    "y",
    "response_seconds",
    "server_seconds",
)
"""Keys of a ``clicks.jsonl`` record (before its checksum), in order; the columns of :func:`load_clicks`."""


def load_clicks(study_dir: str | Path, plan: StudyPlan) -> pd.DataFrame:
    """All participants' accepted clicks (practice included), checked against the plan.

    A ``clicks.jsonl`` written up to 0.2.0 names the label index ``step``; it loads the same.

    Args:
        study_dir: The study folder.
        plan: Its plan.

    Returns:
        One row per click with :data:`CLICK_COLUMNS`, in each file's order; ``label_index`` counts the
        episode's labels from 0, ``response_seconds`` is NaN where the page sent none.

    Raises:
        ValueError: If a line lacks a key (or has both names of the label index, differing), or names
            a participant or trial that contradicts the plan (the message names the file and line).
    """
    records = []
    for participant in plan.participants:
        path = participant_dir(study_dir, participant.id) / "clicks.jsonl"
        if path.exists():
            records.extend(_read_clicks(path, plan, participant.id))
    frame = pd.DataFrame(records, columns=list(CLICK_COLUMNS))
    return frame.astype({"response_seconds": float})


def _read_clicks(path: Path, plan: StudyPlan, participant: str) -> list[dict[str, object]]:
    records = []
    for number, entry in read_json_records(path):
        where = f"{path}:{number}"
        entry = current_study_record(entry, "label_index", where)
        missing = [key for key in CLICK_COLUMNS if key not in entry]
        if missing:
            raise ValueError(f"{where}: the click lacks {missing}")
        if entry["participant"] != participant:
            raise ValueError(f"{where}: participant {entry['participant']!r} in {participant}'s file")
        _trial(plan, participant, entry["trial"], where)
        records.append({key: entry[key] for key in CLICK_COLUMNS})
    return records
