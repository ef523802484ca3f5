"""Whether a participant's files agree with each other and with ``progress.json``.

Every step of the protocol writes its records before ``progress.json`` moves on (a trial's start event, then the
progress; an episode's checkpoint, then its row; a trial's end event, then the progress; an answer, then the progress).
A kill between two writes leaves the records at most one step ahead of the progress file, which the session finishes on
restart. A trial closed with its last background updates still running
(:class:`~antmaze_hirl.study.session.TrialClosing`) has its last rows written after the close, and its ``learner.zip``
last: until then (:func:`closing_trials`) its checkpoint holds those rows. Anything else (``progress.json`` missing
while records exist, records of a trial the progress file has not reached, a finished trial with missing rows, no
``trial_end`` or no answers) is damage, named by :func:`check_records`: a participant is never restarted, nor a trial
closed twice, from files that disagree.
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from antmaze_hirl.study.checkpoint import CHECKPOINT_FILE
from antmaze_hirl.study.data import read_episode_rows
from antmaze_hirl.study.logs import DamagedLog, read_json_records
from antmaze_hirl.study.plan import ParticipantPlan, StudyPlan, TrialPlan

LEARNER_FILE = "learner.zip"
"""A trial's learner after its last update, written last when the trial is done."""


@dataclass
class ParticipantRecords:
    """What a participant's logs hold, per trial index (the plan's :attr:`~TrialPlan.index`).

    Attributes:
        started: Trials with a ``trial_start`` event.
        ended: Trials with a ``trial_end`` event.
        answered: Trials with a questionnaire in ``answers.jsonl``.
        rows: Rows in ``episodes.csv`` per trial.
        checkpoints: Trials whose folder holds a checkpoint.
        final_updates: Trials with a ``final_update`` event (their closing's updates written).
    """

    started: set[int] = field(default_factory=set)
    ended: set[int] = field(default_factory=set)
    answered: set[int] = field(default_factory=set)
    rows: Counter[int] = field(default_factory=Counter)
    checkpoints: set[int] = field(default_factory=set)
    final_updates: set[int] = field(default_factory=set)

    def trials(self) -> set[int]:
        """Every trial index that any record names."""
        return self.started | self.ended | self.answered | set(self.rows) | self.checkpoints

    def where(self, index: int, folder: Path) -> str:
        """The first file that holds a record of trial ``index`` (for a message)."""
        for name, held in (
            ("events.jsonl", self.started | self.ended),
            ("episodes.csv", set(self.rows)),
            ("answers.jsonl", self.answered),
        ):
            if index in held:
                return str(folder / name)
        return str(folder / f"trial{index}")


def read_progress(folder: Path) -> tuple[int, str]:
    """``(trial_index, phase)`` saved in a participant's folder; ``(0, "intro")`` before they start.

    Raises:
        ValueError: If ``progress.json`` is malformed (names the file).
    """
    progress = folder / "progress.json"
    if not progress.is_file():
        return 0, "intro"
    try:
        saved = json.loads(progress.read_text())
        return int(saved["trial_index"]), str(saved["phase"])
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{progress} is not a participant's progress file: {error}") from error


def participant_records(folder: Path) -> ParticipantRecords:
    """Reads a participant's logs (a torn last line is skipped with a warning, as the readers do).

    Raises:
        ValueError: If a log is damaged (:class:`~antmaze_hirl.study.logs.DamagedLog`, naming file and line)
            or a record names no trial (names the file).
    """
    records = ParticipantRecords()
    events = folder / "events.jsonl"
    if events.exists():
        for number, record in read_json_records(events):
            kind = record.get("event")
            held = {"trial_start": records.started, "trial_end": records.ended, "final_update": records.final_updates}
            if kind in held:
                held[kind].add(_trial(record, events, number))
    answers = folder / "answers.jsonl"
    if answers.exists():
        records.answered = {_trial(record, answers, number) for number, record in read_json_records(answers)}
    clicks = folder / "clicks.jsonl"
    if clicks.exists():  # read for its damage only: a changed or repeated line is named here
        read_json_records(clicks)
    episodes = folder / "episodes.csv"
    if episodes.exists():
        for number, row in enumerate(read_episode_rows(episodes), start=2):
            records.rows[_trial(row, episodes, number)] += 1
    for checkpoint in folder.glob("trial*/checkpoint.*"):
        suffix = checkpoint.parent.name.removeprefix("trial")
        if suffix.isdigit():
            records.checkpoints.add(int(suffix))
    return records


def _trial(record: dict, path: Path, number: int) -> int:
    try:
        return int(record["trial"])
    except (KeyError, TypeError, ValueError):
        raise DamagedLog(f"{path}:{number}: names no trial ({record.get('trial')!r})") from None


def closed_trials(participant: ParticipantPlan, trial_index: int, phase: str) -> list[TrialPlan]:
    """The trials that ``(trial_index, phase)`` has closed: those before it, and it at its questionnaire."""
    trials = participant.trials
    current = [trials[trial_index]] if phase == "questionnaire" and trial_index < len(trials) else []
    return list(trials[:trial_index]) + current


def closing_trials(folder: Path, participant: ParticipantPlan, trial_index: int, phase: str) -> list[TrialPlan]:
    """The closed trials whose final update is not written yet: a ``checkpoint.pt`` and no ``learner.zip``.

    Their last rows of ``episodes.csv`` may be missing: the checkpoint holds them, and a running server writes
    them (a restore resumes it).
    """
    return [
        trial
        for trial in closed_trials(participant, trial_index, phase)
        if (folder / f"trial{trial.index}" / CHECKPOINT_FILE).is_file()
        and not (folder / f"trial{trial.index}" / LEARNER_FILE).is_file()
    ]


def check_records(folder: Path, participant: ParticipantPlan, trial_index: int, phase: str) -> bool:
    """Checks that ``folder``'s records agree with ``progress.json``'s ``(trial_index, phase)``.

    Returns:
        Whether the trial at ``trial_index`` has its questionnaire answered already (a kill between the
        answer and the progress file: the session moves on without asking again).

    Raises:
        ValueError: Naming the file whose records disagree: ``progress.json`` missing or behind the logs,
            or a finished trial whose rows, end event or answers are missing.
    """
    records = participant_records(folder)
    progress = folder / "progress.json"
    trials = participant.trials
    positions = {trial.index: position for position, trial in enumerate(trials)}
    found = records.trials()
    unknown = sorted(found - set(positions))
    if unknown:
        raise ValueError(f"{records.where(unknown[0], folder)} has records of trial {unknown[0]}, which is not planned")
    if not progress.is_file():
        if found:
            first = min(found)
            raise ValueError(
                f"{progress} is missing, but {records.where(first, folder)} has records of trial {first}: "
                "restore progress.json from a backup (a participant is never restarted over saved data)"
            )
        return False
    behind = [index for index in found if positions[index] > trial_index]
    current = trials[trial_index] if trial_index < len(trials) else None
    if current is not None:
        index = current.index
        if phase == "intro" and (index in records.ended or index in records.answered or records.rows[index]):
            behind.append(index)
        elif phase == "label" and index in records.answered:
            behind.append(index)
    if behind:
        index = min(behind, key=positions.__getitem__)
        raise ValueError(
            f"{progress} is behind the logs (trial {trial_index + 1} at {phase!r}, but {records.where(index, folder)} "
            f"has later records of trial {index}): it was rolled back or replaced; restore it from a backup"
        )
    # A closing writes a trial's last rows before its final_update event (one lock), so rows may be missing
    # only while that event is not logged: after it, missing rows were removed, never still to be written.
    closing = {
        trial.index
        for trial in closing_trials(folder, participant, trial_index, phase)
        if trial.index not in records.final_updates
    }
    for trial in closed_trials(participant, trial_index, phase):
        rows = records.rows[trial.index]
        if rows != trial.episodes and not (trial.index in closing and rows < trial.episodes):
            raise ValueError(
                f"{folder / 'episodes.csv'} has {records.rows[trial.index]} of the {trial.episodes} rows of "
                f"finished trial {trial.index}: rows were removed (restore the file from a backup)"
            )
        if trial.index not in records.ended:
            raise ValueError(f"{folder / 'events.jsonl'} has no trial_end of finished trial {trial.index}")
        if not trial.practice and trial is not current and trial.index not in records.answered:
            raise ValueError(f"{folder / 'answers.jsonl'} has no questionnaire of finished trial {trial.index}")
    return current is not None and phase == "questionnaire" and current.index in records.answered


def check_study_files(study_dir: str | Path, plan: StudyPlan) -> None:
    """Checks every participant's logs for damage and their agreement with ``progress.json`` (``study analyze``).

    A folder without ``progress.json`` (logs copied or made by hand) has its logs checked for damage only.

    Raises:
        ValueError: Naming the file (and line) of the first damage or disagreement found.
    """
    for participant in plan.participants:
        folder = Path(study_dir) / "participants" / participant.id
        if (folder / "progress.json").is_file():
            trial_index, phase = read_progress(folder)
            check_records(folder, participant, trial_index, phase)
            for trial in closing_trials(folder, participant, trial_index, phase):
                raise ValueError(
                    f"{folder / f'trial{trial.index}'} has no {LEARNER_FILE} yet: trial {trial.index}'s final learner "
                    "update and evaluation are still being written by the study server (which resumes them when it "
                    "starts); analyze once they are"
                )
        elif folder.is_dir():  # logs without a progress file (copied or made by hand): each log's damage only
            participant_records(folder)
