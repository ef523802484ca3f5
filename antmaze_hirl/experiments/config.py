"""The settings of the paper's experiment: plain data, importable without torch (the CLI's defaults)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, TypedDict

from antmaze_hirl.envs.bodies import body_spec
from antmaze_hirl.envs.layout_splits import LayoutSplit
from antmaze_hirl.envs.profiles import BODY_PROFILES, SEEDS

DEFAULT_METHODS = ("dagger", "noise", "multi_policy", "reward", "reward_per_step", "aggrevate")
"""Every query strategy of :data:`antmaze_hirl.dagger.strategies.STRATEGIES`: the paper's four methods, its
Alg. 4 as written (``reward_per_step``) and the AggreVaTe baseline (``aggrevate``)."""


class BodyDefaults(TypedDict):
    """What a body can do in the maze (see :data:`BODY_DEFAULTS`).

    Attributes:
        maze_size: Free cells per side of the random layouts.
        subgoal_reach_m: The oracle's farthest subgoal, metres; ``None``: one cell.
    """

    maze_size: int
    subgoal_reach_m: float | None


BODY_DEFAULTS: dict[str, BodyDefaults] = {
    body: {"maze_size": profile.maze_size, "subgoal_reach_m": profile.subgoal_reach_m}
    for body, profile in BODY_PROFILES.items()
}
"""Maze size and oracle subgoal distance each body can do: the ant experiment's settings and the demo's
(:data:`~antmaze_hirl.envs.profiles.BODY_PROFILES`, which says why)."""

HELD_OUT_MAZE_SIZE: dict[str, int] = {body: profile.held_out_maze_size for body, profile in BODY_PROFILES.items()}
"""Maze size of the held-out-layouts protocol per body. Holding layouts out needs a family with many wall
grids: the ant's 3x3 family has 48 (35 for training), its 4x4 family 1,968
(``results/maze_families/maze_families.json``), on which the oracle driving the shipped ant succeeds nearly
always in 500 steps (docs/results/ant-in-mazes.md)."""


def body_settings(
    body: str, *, held_out_layouts: bool = False, maze_size: int | None = None, subgoal_reach_m: float | None = None
) -> BodyDefaults:
    """A body's maze size and oracle reach, each replaced by its argument when that is not ``None``.

    The defaults are :data:`BODY_DEFAULTS`, with the maze size of :data:`HELD_OUT_MAZE_SIZE` for held-out layouts.

    Raises:
        ValueError: For an unknown body.
    """
    if body not in BODY_DEFAULTS:
        raise ValueError(f"unknown body {body!r}; choose from {sorted(BODY_DEFAULTS)}")
    settings = dict(BODY_DEFAULTS[body])
    if held_out_layouts:
        settings["maze_size"] = HELD_OUT_MAZE_SIZE[body]
    if maze_size is not None:
        settings["maze_size"] = maze_size
    if subgoal_reach_m is not None:
        settings["subgoal_reach_m"] = subgoal_reach_m
    return BodyDefaults(**settings)


SELECTION_SEED = SEEDS.selection
"""With ``held_out_layouts``, periodic evaluation ``i`` resets with seed ``SELECTION_SEED + i``: a seed
range apart from the final evaluation's (from :data:`~antmaze_hirl.dagger.evaluation.HELD_OUT_SEED`) and from
the 2,000,000 on of the lab's ``select_low_level`` mazes, which chose the shipped ant low level."""


PROTOCOLS = (1, 2)
"""The protocols of :attr:`ExperimentConfig.protocol`."""

CURRENT_PROTOCOL = 2
"""The current protocol (docs/guides/protocol.md): :attr:`ExperimentConfig.protocol`'s default, which
``antmaze-hirl experiment`` and ``scripts/paper_experiment.py`` run unless told otherwise."""

PROTOCOL_EVALUATION_ENVS = 25
"""The current protocol's :attr:`ExperimentConfig.evaluation_envs`: its 100-maze set in four lockstep chunks,
several times faster than one maze after another (``benchmarks/paper_trial_speed.py``)."""


def protocol_evaluation_envs(protocol: int) -> int:
    """The ``evaluation_envs`` a protocol runs with unless told otherwise.

    :data:`PROTOCOL_EVALUATION_ENVS` from protocol 2 on; in protocol 1, 1: one maze after another, as its
    committed folders were made.
    """
    return PROTOCOL_EVALUATION_ENVS if protocol >= 2 else 1


@dataclass(frozen=True, kw_only=True)
class TrialSettings:
    """The settings of a trial that the experiment and the user study share, whoever labels.

    :class:`ExperimentConfig` and :class:`~antmaze_hirl.study.settings.StudySettings` are both these fields
    plus their own, so the two cannot drift apart in a name, type or default; a study checks its settings with
    the experiment's checks (:meth:`~antmaze_hirl.study.settings.StudySettings.experiment_config`).

    Attributes:
        body: ``"point"`` or ``"ant"`` (the ant uses its shipped low-level policy).
        maze_size: Free cells per side of the random layouts.
        subgoal_reach_m: The farthest subgoal, metres: the oracle's, and in the study the circle a participant
            clicks in. ``None``: one cell. The ant's shipped low level reaches 2 m subgoals far more reliably
            than 4 m ones (docs/results/ant-in-mazes.md).
        eval_every: M: learner-only evaluation every M episodes.
        eval_episodes: Held-out mazes per intermediate evaluation.
        final_eval_episodes: Held-out mazes at the end.
        gradient_steps: N per update.
        decay: d in ``beta <- beta / d``.
        held_out_layouts: Hold the evaluation mazes out by construction
            (:mod:`antmaze_hirl.envs.layout_splits`): training mazes come from the ``"train"`` part, the
            periodic evaluations from the ``"selection"`` part (seeds from :data:`SELECTION_SEED`: the
            same ``eval_episodes`` mazes every time, a fixed set; about 50 is the intended size), the
            final evaluation from the ``"eval"`` part (seeds from ``HELD_OUT_SEED``), so no evaluation
            maze shares its wall grid with a training maze and the two evaluation sets share none
            either. ``False`` (a study's default; :class:`ExperimentConfig`'s is ``True``, the current
            protocol's): every maze is drawn from the whole family, held out by seed only, and the periodic
            set is the first ``eval_episodes`` mazes of the final one.
    """

    body: str = "point"
    maze_size: int = 5
    subgoal_reach_m: float | None = None
    eval_every: int = 10
    eval_episodes: int = 20
    final_eval_episodes: int = 100
    gradient_steps: int = 200
    decay: float = 2.0
    held_out_layouts: bool = False


@dataclass(frozen=True, kw_only=True)
class ExperimentConfig(TrialSettings):
    """Settings shared by every (method, seed) trial: the :class:`TrialSettings` fields, and these.

    The defaults are the current protocol, :data:`CURRENT_PROTOCOL` (docs/guides/protocol.md): held-out
    layouts, one fixed evaluation set scored from episode 0, evaluated :data:`PROTOCOL_EVALUATION_ENVS` mazes
    at once. Results folders written before then (protocol 1) read through
    :mod:`antmaze_hirl.experiments.old_folders`.

    Attributes:
        held_out_layouts: As :attr:`TrialSettings.held_out_layouts`; ``True`` here (protocol 2 needs it).
        episodes: Training episodes per trial.
        episodes_per_update: K.
        mixing: ``"blend"`` or ``"switch"``.
        protocol: How the curves are read. ``2`` (the default; needs ``held_out_layouts``;
            docs/guides/protocol.md): one fixed set, the ``final_eval_episodes`` mazes of the ``"eval"`` part
            (symmetry-disjoint from training and selection), scored before the first episode (the untrained learner),
            every ``eval_every`` episodes and after the last; ``eval_episodes`` is not used. Every evaluation also
            writes its per-maze outcomes (``evaluations.csv``). ``1`` (the committed
            ``results/paper_experiment`` folders): a periodic set and a different final set, the untrained learner
            not evaluated (its curve starts at ``(0, 0)``).
        learner: The high-level learner, one of :data:`LEARNERS`; ``None``: protocol 2's
            :data:`PROTOCOL_LEARNER`, or in protocol 1 the body's default (the planning learner
            :data:`STRONG_PRIOR` for the point, ``next_cell_cnn`` for the ant).
        evaluation_envs: Mazes an evaluation plays at once, in lockstep
            (:func:`~antmaze_hirl.dagger.evaluation.evaluation_episodes`'s ``num_envs``); the default is
            :data:`PROTOCOL_EVALUATION_ENVS`. ``1`` plays them one after another, as the protocol-1 folders were
            made. The mazes and seeds are the same either way, but batched products round differently, so ant
            outcomes are not replays of serial ones (``docs/guides/vector-envs.md``): a results folder is made
            with one setting, which ``config.json`` records.
        step_gradient_steps: Gradient steps after every labelled step for the strategies that update
            after every step (``reward_per_step``, Alg. 4). 20 gives about the gradient budget of the
            per-episode methods (N = 200 per episode of about 10 labels), so the comparison is of when the
            learner updates, not of how much; ``None`` runs N after every step (10x the compute; its trial
            time is in ``docs/guides/dagger.md``).
    """

    episodes: int = 100
    episodes_per_update: int = 1
    mixing: str = "blend"
    step_gradient_steps: int | None = 20
    protocol: int = CURRENT_PROTOCOL
    learner: str | None = None
    evaluation_envs: int = PROTOCOL_EVALUATION_ENVS
    held_out_layouts: bool = True

    def __post_init__(self) -> None:
        body_spec(self.body)
        for name in (
            "episodes",
            "eval_every",
            "eval_episodes",
            "final_eval_episodes",
            "maze_size",
            "episodes_per_update",
            "evaluation_envs",
        ):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.subgoal_reach_m is not None and not self.subgoal_reach_m > 0:
            raise ValueError(f"subgoal_reach_m must be > 0 metres, got {self.subgoal_reach_m}")
        if self.mixing not in ("blend", "switch"):
            raise ValueError(f"mixing must be 'blend' or 'switch', got {self.mixing!r}")
        if self.step_gradient_steps is not None and self.step_gradient_steps < 1:
            raise ValueError(f"step_gradient_steps must be >= 1 or None, got {self.step_gradient_steps}")
        if not isinstance(self.held_out_layouts, bool):
            raise ValueError(f"held_out_layouts must be True or False, got {self.held_out_layouts!r}")
        if self.learner is not None and self.learner not in LEARNERS:
            raise ValueError(f"unknown learner {self.learner!r}; choose from {sorted(LEARNERS)}")
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {list(PROTOCOLS)}, got {self.protocol!r}")
        if self.protocol >= 2 and not self.held_out_layouts:
            raise ValueError("protocol 2 needs held_out_layouts=True (its evaluation set is the held-out 'eval' part)")

    @property
    def evaluates_untrained(self) -> bool:
        """Whether the untrained learner is evaluated before the first episode (protocol 2)."""
        return self.protocol >= 2


PLANS = -1
"""Stands for ``rows + cols + 2`` value-iteration rounds on the trial's map (:func:`learner_settings`)."""

_SWITCH: dict[str, Any] = {
    "head": "next_cell",
    "planning_iterations": PLANS,
    "block_walls": False,
    "any_map": True,
    "learnt_blocking": True,
    "binary_blocking": True,
}

LEARNERS: dict[str, dict[str, Any]] = {
    "heading_cnn": {"head": "heading", "planning_iterations": 0, "block_walls": False},
    "next_cell_cnn": {"head": "next_cell", "planning_iterations": 0, "block_walls": False},
    "next_cell_vin": {"head": "next_cell", "planning_iterations": PLANS, "block_walls": False},
    "next_cell_vin_walls": {"head": "next_cell", "planning_iterations": PLANS, "block_walls": True},
    "next_cell_plan": {"head": "next_cell", "planning_iterations": PLANS, "block_walls": False, "any_map": True},
    "next_cell_gate": {
        "head": "next_cell",
        "planning_iterations": PLANS,
        "block_walls": False,
        "any_map": True,
        "learnt_blocking": True,
    },
    "next_cell_gate_pressure": {
        "head": "next_cell",
        "planning_iterations": PLANS,
        "block_walls": False,
        "any_map": True,
        "learnt_blocking": True,
        "blocking_pressure": 0.1,
    },
    "next_cell_switch": _SWITCH,
    "next_cell_switch_flat": {**_SWITCH, "switch_flattening": 0.5},
    "next_cell_switch_cell": {**_SWITCH, "cell_switch": True},
    "next_cell_switch_seen": {**_SWITCH, "experience_blocking_weight": 1.0},
}
"""The named high-level learners: :class:`~antmaze_hirl.dagger.HighLevelPolicy` settings, every setting a
body's default sets given explicitly (the variants of ``scripts/learner_ablation.py``). CNN learners see
only the bird's-eye encoding; ``next_cell_vin`` reads the next cell out of value iteration; ``_walls`` also
rules out the moves the walls block, which solves most mazes before any label. ``next_cell_plan`` is the planner
whose weights act on any map; ``next_cell_gate`` adds a learnt gate that can price a move above any path
(``LearnerSettings.learnt_blocking``); ``next_cell_gate_pressure`` also pushes that gate towards blocked on every
move no label holds open (``LearnerSettings.blocking_pressure``); ``next_cell_switch`` makes the gate a switch, each
move open or blocked whatever the map's size (``LearnerSettings.binary_blocking``); ``next_cell_switch_flat`` lets
the switch learn from a softmax twice as flat (``LearnerSettings.switch_flattening``); ``next_cell_switch_cell`` has
one switch per cell, read for the moves into it (``LearnerSettings.cell_switch``); ``next_cell_switch_seen`` also
learns each move's switch from the moves its own DAgger episodes made or failed to make
(``LearnerSettings.experience_blocking_weight``)."""

STRONG_PRIOR = "next_cell_vin_walls"
"""The learner that solves the held-out point mazes untrained (the point's default before protocol 2): a
named ablation, reported beside its untrained success, not the main protocol's learner."""

PROTOCOL_LEARNER = "next_cell_cnn"
"""Protocol 2's learner for both bodies when ``ExperimentConfig.learner`` is not set: the generic CNN
next-cell head, chosen on the selection mazes under the <= 20% untrained-success rule
(``results/untrained_learners/untrained_learners_{point,ant}.json``)."""


def learner_settings(name: str, maze_size: int) -> dict[str, Any]:
    """The settings of learner ``name`` on ``maze_size`` mazes: :data:`PLANS` becomes ``rows + cols + 2`` rounds.

    Raises:
        ValueError: Naming an unknown learner and the known ones.
    """
    if name not in LEARNERS:
        raise ValueError(f"unknown learner {name!r}; choose from {sorted(LEARNERS)}")
    settings = dict(LEARNERS[name])
    if settings["planning_iterations"] == PLANS:
        from antmaze_hirl.dagger.high_level_policy import planning_rounds  # here: this module stays torch-free

        side = maze_size + 2  # the border adds a row and a column on each side
        settings["planning_iterations"] = planning_rounds(side, side)
    return settings


def trial_learner(config: ExperimentConfig) -> str | None:
    """The learner a trial trains: ``config.learner``, else protocol 2's :data:`PROTOCOL_LEARNER`.

    ``None`` in protocol 1 without a learner: the body's default (``HighLevelPolicy.for_env``).
    """
    if config.learner is not None:
        return config.learner
    return PROTOCOL_LEARNER if config.protocol >= 2 else None


def evaluation_schedule(config: ExperimentConfig) -> list[int]:
    """The training episodes after which the learner is evaluated; ``0`` is before the first (protocol 2).

    Every ``eval_every``-th episode and the last, as both protocols have it.
    """
    after = [e for e in range(1, config.episodes + 1) if e % config.eval_every == 0 or e == config.episodes]
    return [0, *after] if config.evaluates_untrained else after


def evaluation_sets(config: ExperimentConfig) -> dict[str, tuple[LayoutSplit, int, int]]:
    """The two evaluation sets: ``{"periodic" | "final": (split, first seed, mazes)}`` (one and the same in protocol 2).

    The split restricts the mazes only with ``held_out_layouts`` (:func:`~antmaze_hirl.experiments.runner.make_env`).
    """
    from antmaze_hirl.dagger.evaluation import HELD_OUT_SEED  # here: the CLI imports this module without torch

    if config.protocol >= 2:  # one set: every evaluation, the untrained one and the last included
        curve = ("eval", HELD_OUT_SEED, config.final_eval_episodes)
        return {"periodic": curve, "final": curve}
    if config.held_out_layouts:
        return {
            "periodic": ("selection", SELECTION_SEED, config.eval_episodes),
            "final": ("eval", HELD_OUT_SEED, config.final_eval_episodes),
        }
    return {
        "periodic": ("eval", HELD_OUT_SEED, config.eval_episodes),
        "final": ("eval", HELD_OUT_SEED, config.final_eval_episodes),
    }
