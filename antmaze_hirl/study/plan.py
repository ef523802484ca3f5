"""The study plan: who does which method in which order, under which neutral label and seed.

Each participant does one practice trial (plain DAgger, recorded but not analysed) and then one
trial per compared method, in an order taken from a Williams design (a balanced Latin square), so
that every method is equally often first, second, ... and follows every other method equally often.
Participants only ever see neutral labels ("Method A", ...), fixed for the whole study.
"""

from __future__ import annotations

import json
import re
from collections.abc import Collection, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.envs.simulator import BODY_SPECS

MAX_METHODS = 8
"""More methods than this make a session too long (and the label alphabet is kept short)."""

PRACTICE_METHOD = "dagger"
PRACTICE_LABEL = "Practice"
PLAN_FILE = "plan.json"


def williams_design(n_methods: int) -> list[list[int]]:
    """Williams design: orders of ``n_methods`` methods balanced for position and first-order carryover.

    For an even ``n_methods`` the ``n`` rows form a Latin square in which every ordered pair of methods
    is adjacent exactly once; an odd ``n`` needs the square and its mirror (``2n`` rows), where every
    ordered pair is adjacent exactly twice.

    Args:
        n_methods: How many methods, at least 1.

    Returns:
        The rows, each a permutation of ``range(n_methods)``.

    Raises:
        ValueError: If ``n_methods`` is not a positive int.
    """
    if isinstance(n_methods, bool) or not isinstance(n_methods, int) or n_methods < 1:
        raise ValueError(f"n_methods must be a positive int, got {n_methods!r}")
    if n_methods == 1:
        return [[0]]  # nothing to balance; the mirror would only repeat the row
    # The classic first row 0, 1, n-1, 2, n-2, ...; the other rows add 1, 2, ... modulo n.
    first = [0]
    low, high = 1, n_methods - 1
    while len(first) < n_methods:
        first.append(low)
        low += 1
        if len(first) < n_methods:
            first.append(high)
            high -= 1
    square = [[(method + shift) % n_methods for method in first] for shift in range(n_methods)]
    if n_methods % 2 == 0:
        return square
    return square + [row[::-1] for row in square]


@dataclass(frozen=True)
class TrialPlan:
    """One trial of one participant.

    Attributes:
        index: Position in the session; 0 is the practice trial, the compared methods are 1, 2, ...
            (with or without a practice trial).
        method: The method's name (never shown to the participant).
        label: What the participant sees ("Method A", ... or "Practice").
        episodes: Training episodes in the trial.
        practice: Whether this is the practice trial (recorded but not analysed).
        seed: The trial's seed; no two trials of a study share one.
    """

    index: int
    method: str
    label: str
    episodes: int
    practice: bool
    seed: int


@dataclass(frozen=True)
class ParticipantPlan:
    """The trials of one participant, in session order.

    Attributes:
        id: Anonymous id, ``P01``, ``P02``, ...
        trials: The trials, practice first (if any).
    """

    id: str
    trials: tuple[TrialPlan, ...]

    @property
    def order(self) -> tuple[str, ...]:
        """The compared methods in the order this participant does them (practice left out)."""
        return tuple(trial.method for trial in self.trials if not trial.practice)


@dataclass(frozen=True)
class StudyPlan:
    """A whole study.

    Attributes:
        body: ``"point"`` or ``"ant"``.
        methods: The compared methods (names of :data:`antmaze_hirl.dagger.strategies.METHODS`).
        labels: ``(method, label)`` pairs: each method's neutral label, fixed for the whole study.
        episodes: Episodes per compared trial.
        practice: Episodes of the practice trial (0: no practice trial).
        seed: The study seed every order, label and trial seed is derived from.
        participants: The participants' plans.
    """

    body: str
    methods: tuple[str, ...]
    labels: tuple[tuple[str, str], ...]
    episodes: int
    practice: int
    seed: int
    participants: tuple[ParticipantPlan, ...]

    def label_of(self, method: str) -> str:
        """The neutral label of ``method``.

        Raises:
            ValueError: If ``method`` is not in the study.
        """
        for name, label in self.labels:
            if name == method:
                return label
        raise ValueError(f"method {method!r} is not in the study; its methods are {list(self.methods)}")

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (the content of ``plan.json``)."""
        return asdict(self)


def _known_methods() -> list[str]:
    # Imported here: the study kit (layer 7) reads the trainer's strategies (dagger, layer 5), not the reverse.
    from antmaze_hirl.dagger.strategies import METHODS

    return list(METHODS)


MAX_PARTICIPANTS = 10_000
"""Most participants a plan holds (a study of more is a typo)."""

MAX_EPISODES = 100_000
"""Most episodes a trial holds."""

MAX_SEED = 2**32 - 1
"""Largest study or trial seed (numpy's seeds are 32-bit words; trial seeds stay below this)."""

SAFE_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
"""A participant id: it names a folder, so letters, digits, ``_`` and ``-`` only, at most 64."""


def _check_count(name: str, value: object, minimum: int, maximum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not minimum <= value <= maximum:
        raise ValueError(f"{name} must be an int in [{minimum}, {maximum}], got {value!r}"[:200])
    return value


def _check_methods(methods: Sequence[str], known: Collection[str]) -> tuple[str, ...]:
    if isinstance(methods, str):
        raise ValueError(f"methods must be a list of method names, got the string {methods!r}")
    methods = tuple(methods)
    if not methods:
        raise ValueError("methods is empty; name at least one method")
    for method in methods:
        if method not in known:
            raise ValueError(f"unknown method {method!r}; choose from {sorted(known)}")
    for method in methods:
        if methods.count(method) > 1:
            raise ValueError(f"method {method!r} is listed {methods.count(method)} times; list each method once")
    if len(methods) > MAX_METHODS:
        raise ValueError(f"{len(methods)} methods {list(methods)}: the design supports at most {MAX_METHODS}")
    return methods


def _trial_seed(base: int, participant: int, trial: int, trials_per_participant: int) -> int:
    # One slot per (participant, trial) after a study-wide offset: distinct within the study by
    # construction, and unrelated between studies with different seeds.
    return base + participant * trials_per_participant + trial


def make_plan(
    body: str,
    methods: Sequence[str],
    participants: int,
    episodes: int = 100,
    practice: int = 30,
    seed: int = 0,
    known_methods: Collection[str] | None = None,
) -> StudyPlan:
    """Plans a study: orders from a shuffled Williams design, seeded neutral labels and trial seeds.

    Participant ``i`` (``P01`` is 0) gets row ``i % len(rows)`` of the design, whose rows are shuffled
    by ``np.random.default_rng(seed)``; full carryover balance needs a multiple of ``len(rows)``
    participants.

    Args:
        body: ``"point"`` or ``"ant"``.
        methods: The compared methods, each once.
        participants: How many participants, at least 1.
        episodes: Episodes per compared trial, at least 1.
        practice: Episodes of the practice trial (plain DAgger); 0 for no practice trial.
        seed: Study seed, a non-negative int.
        known_methods: The allowed method names (default: the trainer's strategies).

    Returns:
        The plan.

    Raises:
        ValueError: On any invalid argument (the message names it).
    """
    if body not in BODY_SPECS:
        raise ValueError(f"unknown body {body!r}; choose one of {sorted(BODY_SPECS)}")
    methods = _check_methods(methods, _known_methods() if known_methods is None else known_methods)
    _check_count("participants", participants, 1, MAX_PARTICIPANTS)
    _check_count("episodes", episodes, 1, MAX_EPISODES)
    _check_count("practice", practice, 0, MAX_EPISODES)
    _check_count("seed", seed, 0, MAX_SEED)
    rng = np.random.default_rng(seed)
    rows = williams_design(len(methods))
    rows = [rows[i] for i in rng.permutation(len(rows))]
    letters = [chr(ord("A") + i) for i in range(len(methods))]
    shuffled = [letters[i] for i in rng.permutation(len(methods))]
    labels = {method: f"Method {letter}" for method, letter in zip(methods, shuffled, strict=True)}
    base = int(rng.integers(0, 2**31))  # + at most MAX_PARTICIPANTS * (MAX_METHODS + 1) slots: below MAX_SEED
    slots = len(methods) + 1  # trial 0 is the practice slot, used or not
    plans = []
    for i in range(participants):
        trials = []
        if practice:
            trials.append(TrialPlan(0, PRACTICE_METHOD, PRACTICE_LABEL, practice, True, _trial_seed(base, i, 0, slots)))
        for k, m in enumerate(rows[i % len(rows)], start=1):
            trials.append(TrialPlan(k, methods[m], labels[methods[m]], episodes, False, _trial_seed(base, i, k, slots)))
        plans.append(ParticipantPlan(f"P{i + 1:02d}", tuple(trials)))
    ordered_labels = tuple(sorted(labels.items(), key=lambda item: item[1]))
    return StudyPlan(body, methods, ordered_labels, episodes, practice, seed, tuple(plans))


def save_plan(plan: StudyPlan, directory: str | Path) -> Path:
    """Writes ``directory/plan.json`` atomically; saving the same plan again is allowed.

    Args:
        plan: The plan.
        directory: The study folder (created if missing).

    Returns:
        The path of ``plan.json``.

    Raises:
        ValueError: If ``plan.json`` already exists with a different plan (a study's plan never changes).
    """
    path = Path(directory) / PLAN_FILE
    content = json.loads(json.dumps(plan.to_dict()))  # as it reads back: tuples become lists
    if path.exists():
        try:
            same = json.loads(path.read_text()) == content
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            same = False
        if not same:
            raise ValueError(f"{path} already holds a different plan; a study's plan never changes (use a new folder)")
    return atomic_write_json(path, content, allow_nan=False)


def load_plan(directory: str | Path, known_methods: Collection[str] | None = None) -> StudyPlan:
    """Reads and validates ``directory/plan.json``.

    Args:
        directory: The study folder.
        known_methods: The allowed method names (default: the trainer's strategies).

    Returns:
        The plan.

    Raises:
        ValueError: If the file is missing, is not JSON, or does not hold a valid plan (the message names it).
    """
    path = Path(directory) / PLAN_FILE
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"no study plan at {path}; make one first") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path} is not a readable JSON plan: {error}") from None
    try:
        return _plan_from_dict(data, known_methods)
    except (ValueError, TypeError, KeyError) as error:
        raise ValueError(f"{path} is not a valid study plan: {error}") from None


def _fields(data: object, names: Sequence[str], what: str) -> dict[str, Any]:
    if not isinstance(data, dict) or set(data) != set(names):
        keys = sorted(data) if isinstance(data, dict) else type(data).__name__
        raise ValueError(f"{what} must have exactly the keys {sorted(names)}, got {keys}")
    return data


def _typed(value: object, kind: type, what: str) -> Any:
    if isinstance(value, bool) != (kind is bool) or not isinstance(value, kind):
        raise ValueError(f"{what} must be a {kind.__name__}, got {value!r}")
    return value


def _plan_from_dict(data: object, known_methods: Collection[str] | None) -> StudyPlan:
    top = _fields(data, ("body", "methods", "labels", "episodes", "practice", "seed", "participants"), "the plan")
    # The settings go through make_plan's own checks, so a hand-edited file fails the same way.
    settings = make_plan(top["body"], top["methods"], 1, top["episodes"], top["practice"], top["seed"], known_methods)
    if not isinstance(top["labels"], list) or not all(isinstance(p, list) and len(p) == 2 for p in top["labels"]):
        raise ValueError(f"labels must be a list of [method, label] pairs, got {top['labels']!r}")
    labels = tuple((_typed(m, str, "a label's method"), _typed(lab, str, "a label")) for m, lab in top["labels"])
    if not isinstance(top["participants"], list) or not top["participants"]:
        raise ValueError(f"participants must be a non-empty list, got {top['participants']!r}")
    participants = tuple(_participant_from_dict(entry) for entry in top["participants"])
    plan = StudyPlan(
        settings.body, settings.methods, labels, settings.episodes, settings.practice, settings.seed, participants
    )
    _check_consistent(plan)
    return plan


def _participant_from_dict(entry: object) -> ParticipantPlan:
    fields = _fields(entry, ("id", "trials"), "a participant")
    if not isinstance(fields["trials"], list):
        raise ValueError(f"a participant's trials must be a list, got {fields['trials']!r}")
    trials = []
    for trial in fields["trials"]:
        t = _fields(trial, ("index", "method", "label", "episodes", "practice", "seed"), "a trial")
        trials.append(
            TrialPlan(
                _typed(t["index"], int, "a trial index"),
                _typed(t["method"], str, "a trial method"),
                _typed(t["label"], str, "a trial label"),
                _typed(t["episodes"], int, "a trial's episodes"),
                _typed(t["practice"], bool, "a trial's practice flag"),
                _typed(t["seed"], int, "a trial seed"),
            )
        )
    participant_id = _typed(fields["id"], str, "a participant id")
    if not SAFE_ID.match(participant_id):
        # The id names the participant's folder: "../x" or "a/b" would write outside the study.
        raise ValueError(f"participant id {participant_id[:80]!r} is not a safe name ({SAFE_ID.pattern})")
    for trial in trials:
        _check_count(f"participant {participant_id}'s trial seed", trial.seed, 0, MAX_SEED)
    return ParticipantPlan(participant_id, tuple(trials))


def _check_consistent(plan: StudyPlan) -> None:
    """The invariants make_plan guarantees, for a plan read from disk."""
    label_methods = [method for method, _ in plan.labels]
    label_names = [label for _, label in plan.labels]
    if sorted(label_methods) != sorted(plan.methods) or len(set(label_names)) != len(label_names):
        raise ValueError(f"labels {dict(plan.labels)} must give each method of {list(plan.methods)} its own label")
    ids = [participant.id for participant in plan.participants]
    if len(set(ids)) != len(ids):
        raise ValueError(f"participant ids repeat: {ids}")
    seeds = [trial.seed for participant in plan.participants for trial in participant.trials]
    if len(set(seeds)) != len(seeds):
        raise ValueError("two trials share a seed")
    practice = (TrialPlan(0, PRACTICE_METHOD, PRACTICE_LABEL, plan.practice, True, 0),) if plan.practice else ()
    for participant in plan.participants:
        compared = [
            TrialPlan(k, method, plan.label_of(method), plan.episodes, False, 0)
            for k, method in enumerate(participant.order, start=1)
        ]
        # Seeds are checked above; everything else follows from the settings and the order.
        found = [replace(trial, seed=0) for trial in participant.trials]
        if found != [*practice, *compared] or sorted(participant.order) != sorted(plan.methods):
            raise ValueError(f"participant {participant.id}'s trials do not match the plan's settings")
