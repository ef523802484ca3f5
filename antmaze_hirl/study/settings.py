"""What every trial of a study runs with: maze family, expert reach, evaluation and update settings."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.experiments.config import ExperimentConfig, TrialSettings, body_settings
from antmaze_hirl.experiments.old_folders import current_settings

SETTINGS_FILE = "settings.json"

SECONDS_PER_MAZE_PRIOR = 22.4
"""Seconds a maze takes a participant, for the page's estimate before they have played one (and ``study init``'s
estimate of a sitting). The default study's mean from ``scripts/study_sitting.py``: the oracle's clicks per
maze on the point, the page's walk animations and the server's times, measured, and 3 s to think of a click,
**assumed** (no person was timed; docs/guides/user-study.md). Once the participant has finished mazes, their
own mean time per maze replaces it."""

QUESTIONNAIRE_SECONDS = 90.0
"""Seconds a questionnaire takes, for the page's estimate of what is left."""


@dataclass(frozen=True, kw_only=True)
class StudySettings(TrialSettings):
    """Settings shared by every trial of a study (the method and seed come from the plan).

    The :class:`~antmaze_hirl.experiments.config.TrialSettings` fields (:data:`EXPERIMENT_FIELDS`: the
    experiment's names, types and defaults; ``subgoal_reach_m`` is the radius of the circle a participant clicks
    in) and the page's. Their names are the keys of a study's ``settings.json`` (files from before 0.2.0 hold
    some under older keys, read through :func:`~antmaze_hirl.experiments.old_folders.current_settings`).
    ``held_out_layouts`` is ``False`` by default, as it always was, so that a study folder written before
    the setting existed reads as what it ran; ``study init`` (:meth:`for_body`) sets it.

    Attributes:
        show_learner_subgoal: Draw the learner's proposed subgoal on the page.
        background_updates: Run the learner update (and a due evaluation) after each maze in a background
            thread while the next maze starts with the learner as it was: no wait between mazes, and the
            learner lags one maze (:mod:`antmaze_hirl.study.background`); after a trial's last maze the
            trial closes at once and its last updates and final evaluation are written after it
            (:class:`~antmaze_hirl.study.session.TrialClosing`). ``False`` (the default, so that a study
            folder written before the setting reads as what it ran): the update runs before the next maze, as
            in the experiments. ``study init`` (:meth:`for_body`) sets it.
    """

    show_learner_subgoal: bool = True
    background_updates: bool = False

    def __post_init__(self) -> None:
        check_cli_bounds(self)
        self.experiment_config(1)  # the experiment's checks name any bad value
        for name in ("subgoal_reach_m", "decay"):  # never NaN or Infinity in settings.json (not JSON)
            value = getattr(self, name)
            if value is not None and not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        for name in ("show_learner_subgoal", "background_updates"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be true or false, got {getattr(self, name)!r}")
        if self.held_out_layouts:
            check_family_splits(self.maze_size)

    @classmethod
    def for_body(cls, body: str, **overrides: Any) -> StudySettings:
        """The paper protocol's maze family and reach for ``body``, held out, background updates on, and ``overrides``.

        Raises:
            ValueError: For an unknown body or setting, or a maze size whose family cannot be held out
                (:func:`check_family_splits`).
        """
        known = {field.name for field in fields(cls)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ValueError(f"unknown study setting(s) {unknown}; known: {sorted(known)}")
        held_out = overrides.pop("held_out_layouts", True)
        background = overrides.pop("background_updates", True)
        family = body_settings(body, held_out_layouts=held_out)
        return cls(body=body, held_out_layouts=held_out, background_updates=background, **{**family, **overrides})

    def experiment_config(self, episodes: int) -> ExperimentConfig:
        """The experiment settings of one trial of ``episodes`` episodes (so the study runs the experiment's code).

        A study evaluates as protocol 1 does, one maze after another, as it always has: the experiment's defaults
        are the current protocol's, which a study's settings do not record.
        """
        settings = {name: getattr(self, name) for name in EXPERIMENT_FIELDS}
        return ExperimentConfig(episodes=episodes, protocol=1, evaluation_envs=1, **settings)


def check_cli_bounds(settings: StudySettings) -> None:
    """Checks every numeric setting against the bounds ``study init`` gives its option (``decay`` >= 1, ...).

    A ``settings.json`` edited by hand gets the same checks as the command line, so that a value the CLI
    refuses (``"decay": -1``) never reaches a trial.

    Raises:
        ValueError: Naming the setting, its bounds and the value.
    """
    from antmaze_hirl.cli_validation import FLOAT_BOUNDS, INT_BOUNDS

    for field in fields(settings):
        name, value = field.name, getattr(settings, field.name)
        if value is None or isinstance(value, bool):
            continue
        ints = INT_BOUNDS.get(f"study init:{name}", INT_BOUNDS.get(name))
        floats = FLOAT_BOUNDS.get(f"study init:{name}", FLOAT_BOUNDS.get(name))
        if ints is not None and not (isinstance(value, int) and ints.low <= value <= ints.high):
            raise ValueError(f"{name} must be an int in [{ints.low}, {ints.high}], got {value!r}")
        if floats is not None:
            number = value if isinstance(value, int | float) else math.nan
            above = number >= floats.low if floats.low_inclusive else number > floats.low
            if not (math.isfinite(number) and above and number <= floats.high):
                raise ValueError(f"{name} must be {floats.describe()}, got {value!r}")


EXPERIMENT_FIELDS: tuple[str, ...] = tuple(field.name for field in fields(TrialSettings))
"""The :class:`StudySettings` fields that are :class:`~antmaze_hirl.experiments.config.ExperimentConfig`'s too
(the :class:`~antmaze_hirl.experiments.config.TrialSettings` fields): :meth:`StudySettings.experiment_config`
passes them on."""


STUDY_SPLITS = ("train", "selection", "eval")
"""The parts of the layout partition a held-out study draws from: training, periodic and final evaluation."""


def check_family_splits(maze_size: int) -> None:
    """Checks that the random mazes of ``maze_size`` can be drawn in every part a held-out study uses.

    Draws as the trial's envs do (:class:`~antmaze_hirl.envs.split_env.SplitMazeEnv` with the env's
    default wall fraction and goal distance), so a study whose trial could not start is refused at ``study init``.

    Raises:
        ValueError: Naming ``maze_size`` and the part with no wall grid of that family.
    """
    import inspect

    import numpy as np

    from antmaze_hirl.envs.high_level import HighLevelMazeEnv
    from antmaze_hirl.envs.layout_splits import sample_layout_in_split
    from antmaze_hirl.envs.layouts import generate_layout

    defaults = inspect.signature(HighLevelMazeEnv.__init__).parameters

    def sample(rng: np.random.Generator) -> Any:
        return generate_layout(
            rng,
            n_rows=maze_size,
            n_cols=maze_size,
            wall_fraction=defaults["wall_fraction"].default,
            min_goal_cells=defaults["min_goal_cells"].default,
        )

    for split in STUDY_SPLITS:
        try:
            sample_layout_in_split(sample, np.random.default_rng(0), split)
        except ValueError as error:
            raise ValueError(f"maze_size {maze_size} cannot be used with held-out layouts: {error}") from None


def save_settings(settings: StudySettings, study_dir: str | Path) -> Path:
    """Writes ``DIR/settings.json`` atomically."""
    return atomic_write_json(Path(study_dir) / SETTINGS_FILE, asdict(settings), allow_nan=False)


def load_settings(study_dir: str | Path) -> StudySettings:
    """Reads ``DIR/settings.json``.

    Raises:
        FileNotFoundError: If the study has no settings file (not made by ``antmaze-hirl study init``).
        ValueError: If the file is not valid settings, or holds a setting under its old and new keys with two
            values (names the file).
    """
    path = Path(study_dir) / SETTINGS_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: create the study with 'antmaze-hirl study init {study_dir}'")
    try:
        return StudySettings(**current_settings(json.loads(path.read_text()), path))
    except (json.JSONDecodeError, TypeError, ValueError) as error:
        raise ValueError(f"{path} holds no valid study settings: {error}") from error
