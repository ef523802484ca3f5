"""The high-level learner: its settings (:class:`LearnerSettings`) and :class:`HighLevelPolicy`, the DAgger learner.

:class:`HighLevelPolicy` holds a torch network of :mod:`antmaze_hirl.dagger.network` (which subgoal to
hand the low level), fits it to expert subgoals, and saves it to and loads it from a zip. Every setting it
has is a field of :class:`LearnerSettings`, the one list of them: the constructor takes one, a body's
defaults are one (:meth:`LearnerSettings.for_body`), and a saved file's ``config`` holds its fields.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from torch import nn

from antmaze_hirl.atomic_io import atomic_write_bytes
from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import OFFSET_FEATURE_DIM, EncodedBatch, ObservationEncoder, augment
from antmaze_hirl.dagger.network import (
    NEXT_CELL_MOVES,
    NextCellNetwork,
    SubgoalNetwork,
    direction_bins,
    next_cell_classes,
    offsets_from_outputs,
)
from antmaze_hirl.dagger.optim import ZeroSafeAdam
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.profiles import BODY_PROFILES
from antmaze_hirl.envs.protocol import maze_env
from antmaze_hirl.envs.state_layout import STATE_LAYOUT

FORMAT = "antmaze_hirl.high_level_policy/2"
"""The format a saved learner's ``meta.json`` names (the files of every 0.x version)."""

HEADS = ("heading", "next_cell")
"""What the network outputs: a free heading and distance, or the next cell of the path (3x3 around the agent)."""

ENV_SHAPE_KEYS = ("geometry", "pixels_per_cell", "body_dim")
"""What a saved file's ``config`` holds beside the :class:`LearnerSettings` fields: the shape of the env it acts
in (map placement as ``[rows, cols, scale]``, image resolution, body observation length)."""

FILE_KEYS = {"subgoal_reach_m": "max_offset"}
"""Settings a zip's ``config`` stores under another key: format 2 predates the 0.2.0 names, and the committed
and shipped files keep reading only if the key in the file stays (:meth:`HighLevelPolicy.save`,
:func:`read_policy_file` translate)."""

AT_REACH = 0.9
"""Share of ``subgoal_reach_m`` from which a label counts as cut short at the reach (the oracle's are exactly at it;
a noisy or human click a little short of it still points past it)."""


def planning_rounds(n_rows: int, n_cols: int) -> int:
    """Value-iteration rounds of a planning next-cell head on an ``n_rows x n_cols`` map (border included).

    ``rows + cols + 2``: enough moves for the map's longest shortest path.
    """
    return n_rows + n_cols + 2


@dataclass(frozen=True)
class LearnerSettings:
    """Every setting of a :class:`HighLevelPolicy`: its network's shape and how it is trained.

    The fields are in the order a saved file's ``config`` lists them (after :data:`ENV_SHAPE_KEYS`).

    Attributes:
        subgoal_reach_m: Farthest subgoal from the agent, metres; ``None``: one cell (the oracle's default
            reach; the experiment passes its oracle's ``subgoal_reach_m``, the ant's 2 m). The learner
            resolves ``None`` to its map's cell side.
        n_directions: Heading bins of the ``"heading"`` network (a positive multiple of 4, so the square's
            symmetries map bins to bins).
        planning_iterations: Value-iteration rounds (0, the default: CNN only). With the heading head,
            value-iteration features beside the CNN's (on 5x5 point mazes they did not beat the CNN:
            docs/lab-notes.md, "The high-level policy's value-iteration module"); with the next-cell head, the planner
            whose Q gives the logits, which needs at least the longest path's moves (:func:`planning_rounds`).
        channels: Convolution channels.
        hidden: Width of the fully connected layers.
        head: ``"heading"`` (the default; :meth:`for_body` picks per body): classify a heading among
            ``n_directions`` and regress a distance. ``"next_cell"``: classify which of the 3x3 cells around
            the agent's cell comes next on the path (a label's class is the cell its subgoal lies in); the
            subgoal is that cell's centre, or the goal where the goal lies in it, pulled back to
            ``subgoal_reach_m``. With ``planning_iterations > 0`` its logits are a value iteration network's Q
            at the agent's cell.
        block_walls: With the ``"next_cell"`` head's value iteration: moves into a wall, or diagonally
            between two, are ruled out (the walls read from the image). Needs ``planning_iterations > 0``.
        any_map: With the ``"next_cell"`` head's value iteration: the planning learner whose weights act on
            any map (:class:`~antmaze_hirl.dagger.network.NextCellNetwork`'s ``any_map``: the planner's Q
            alone, times a trust learnt from 0; :meth:`HighLevelPolicy.on_map`). Needs ``planning_iterations > 0``.
        learnt_blocking: With the ``"next_cell"`` head's value iteration: a learnt gate per move that can price
            it above any path on any map (:class:`~antmaze_hirl.dagger.network.CellValueIteration`); walls are
            learnt, not given, so it excludes ``block_walls``. Needs ``planning_iterations > 0``.
        blocking_pressure: With ``learnt_blocking``: weight of a loss term in :meth:`HighLevelPolicy.fit`,
            ``mean(-log b)`` over every move of every cell of the grid, that pushes each gate ``b`` towards
            blocked; the labels' cross-entropy holds open the moves their paths make. Why: a margin loss
            only prices a move into a wall above the training mazes' detours (a learnt cost of a few moves,
            and walls walked into on larger maps); the pressure keeps pricing a move that no label makes,
            whatever the map's size. It pushes the labels' own moves too, and the labels hold open only the
            moves of the value iteration's best path: at 0.1 on the ant's grid it traded moves into walls for
            rollouts that stay in their cell (``results/planning_learner/selection/looks/pressure_grid_ant.json``).
            0 (the default): no such term.
        binary_blocking: With ``learnt_blocking``: the gate is a switch, each move open or blocked (its logit
            above 0 adds :data:`~antmaze_hirl.dagger.network.BLOCKED_COST`), learnt through a surrogate
            gradient (:class:`~antmaze_hirl.dagger.network.CellValueIteration`); every gate starts open. Why: a
            continuous gate is priced like any cost, only as high as the training mazes' detours need (two
            looks in ``results/planning_learner/selection/``), while a switch, once pushed across 0, blocks the
            move on a map of any size. ``False`` (the default): the sigmoid gate.
        switch_flattening: With ``binary_blocking`` and ``any_map``: the switch learns from a second
            cross-entropy whose softmax is this much flatter (the trust times it; Q and the trust held there),
            the trust and the costs from the logits' own (:meth:`HighLevelPolicy.fit`). Why: with the logits'
            own softmax, a move into a wall that the learnt costs price a few moves out on the 4x4 training mazes
            has almost no weight, so its switch stops being pushed before it shuts (diagonal moves into a wall's
            end, on 8x8 maps). 1.0 (the default): one cross-entropy.
        cell_switch: With ``binary_blocking``: one switch per cell, read for every move into that cell, not one per
            move (:class:`~antmaze_hirl.dagger.network.CellValueIteration`'s ``cell_blocking``). Learnt: which cells
            are shut, from each cell's own view, every cell starting open; fixed: that a move's switch is its
            destination cell's (a grid world's transition form). Why: a per-move gate reads a free move no label
            made as it reads a wall and shut free moves; every labelled move enters a free cell, so the labels
            hold the free cells' view open. ``False`` (the default): one switch per move.
        experience_blocking_weight: With ``binary_blocking``: weight of a loss term in :meth:`HighLevelPolicy.fit`
            on the moves the learner's own training episodes tried (:meth:`HighLevelPolicy.observe_step`, fed by
            the DAgger trainer with what it already executes: no env step and no label more): a logistic loss on
            the switch logit of each tried move (the per-move switch at the source cell, or with ``cell_switch``
            the destination cell's), towards shut for a move whose walk ended outside the cell moved towards
            (subgoal not reached, no fall, no goal) and towards open for a move whose walk entered that cell.
            Learnt: which moves are blocked, from what happened; the walls are only an input. Why: DAgger's labels
            lie near goals and rarely rank a wall move above the label, so the cross-entropy seldom pushes a wall's
            switch shut (``results/planning_learner/selection/README.md``, eighth look), while the learner's own
            walks into walls are blocked moves it has seen. 0 (the default): no such term, nothing recorded.
        learning_rate: Adam step size.
        batch_size: Minibatch size of :meth:`HighLevelPolicy.fit`.
        augment_symmetries: Train on random rotations/mirrors of each sample.

    Raises:
        ValueError: Naming the first bad value: ``subgoal_reach_m`` not positive, ``n_directions`` not a
            positive multiple of 4, ``planning_iterations`` negative, ``channels`` or ``hidden`` below 1,
            ``head`` unknown, ``block_walls`` without the planning next-cell head, ``blocking_pressure``
            negative or set without ``learnt_blocking``, ``binary_blocking`` without ``learnt_blocking``,
            ``binary_blocking`` with ``blocking_pressure``, ``switch_flattening`` outside ``(0, 1]`` or below 1
            without ``binary_blocking`` and ``any_map``, ``cell_switch`` without ``binary_blocking``,
            ``experience_blocking_weight`` negative, not finite or set without ``binary_blocking``,
            ``learning_rate`` not positive or ``batch_size`` below 1.
    """

    subgoal_reach_m: float | None = None
    n_directions: int = 16
    planning_iterations: int = 0
    channels: int = 16
    hidden: int = 128
    head: str = "heading"
    block_walls: bool = False
    any_map: bool = False
    learnt_blocking: bool = False
    learning_rate: float = 1e-3
    batch_size: int = 64
    augment_symmetries: bool = True
    blocking_pressure: float = 0.0
    binary_blocking: bool = False
    switch_flattening: float = 1.0
    cell_switch: bool = False
    experience_blocking_weight: float = 0.0

    def __post_init__(self) -> None:
        if self.subgoal_reach_m is not None and not self.subgoal_reach_m > 0:
            raise ValueError(f"subgoal_reach_m must be > 0 or None, got {self.subgoal_reach_m}")
        if self.n_directions < 4 or self.n_directions % 4:
            raise ValueError(f"n_directions must be a positive multiple of 4, got {self.n_directions}")
        if self.head not in HEADS:
            raise ValueError(f"head must be one of {list(HEADS)}, got {self.head!r}")
        if self.planning_iterations < 0:
            raise ValueError(f"planning_iterations must be >= 0, got {self.planning_iterations}")
        if self.block_walls and (self.head != "next_cell" or self.planning_iterations == 0):
            raise ValueError("block_walls needs head='next_cell' and planning_iterations > 0")
        if self.any_map and (self.head != "next_cell" or self.planning_iterations == 0):
            raise ValueError("any_map needs head='next_cell' and planning_iterations > 0")
        if self.learnt_blocking and (self.head != "next_cell" or self.planning_iterations == 0 or self.block_walls):
            raise ValueError("learnt_blocking needs head='next_cell', planning_iterations > 0 and no block_walls")
        object.__setattr__(self, "any_map", bool(self.any_map))
        object.__setattr__(self, "learnt_blocking", bool(self.learnt_blocking))
        if not (self.blocking_pressure >= 0 and math.isfinite(self.blocking_pressure)):
            raise ValueError(f"blocking_pressure must be finite and >= 0, got {self.blocking_pressure}")
        if self.blocking_pressure and not self.learnt_blocking:
            raise ValueError(f"blocking_pressure needs learnt_blocking, got {self.blocking_pressure} without it")
        object.__setattr__(self, "blocking_pressure", float(self.blocking_pressure))
        if self.binary_blocking and not self.learnt_blocking:
            raise ValueError("binary_blocking needs learnt_blocking: it makes the learnt gate a switch")
        if self.binary_blocking and self.blocking_pressure:
            raise ValueError("binary_blocking and blocking_pressure exclude each other: the switch has its own push")
        object.__setattr__(self, "binary_blocking", bool(self.binary_blocking))
        if not 0 < self.switch_flattening <= 1:
            raise ValueError(f"switch_flattening must be in (0, 1], got {self.switch_flattening}")
        if self.switch_flattening != 1.0 and not (self.binary_blocking and self.any_map):
            raise ValueError(f"switch_flattening needs binary_blocking and any_map, got {self.switch_flattening}")
        object.__setattr__(self, "switch_flattening", float(self.switch_flattening))
        if self.cell_switch and not self.binary_blocking:
            raise ValueError("cell_switch needs binary_blocking: it makes the switch one per cell")
        object.__setattr__(self, "cell_switch", bool(self.cell_switch))
        weight = self.experience_blocking_weight
        if not (weight >= 0 and math.isfinite(weight)):
            raise ValueError(f"experience_blocking_weight must be finite and >= 0, got {weight}")
        if weight and not self.binary_blocking:
            raise ValueError(f"experience_blocking_weight needs binary_blocking, got {weight} without it")
        object.__setattr__(self, "experience_blocking_weight", float(weight))
        for name in ("channels", "hidden", "batch_size"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not self.learning_rate > 0:
            raise ValueError(f"learning_rate must be > 0, got {self.learning_rate}")
        # The types the network and a saved file's JSON get (a numpy integer from a caller, say): frozen, so set here.
        if self.subgoal_reach_m is not None:
            object.__setattr__(self, "subgoal_reach_m", float(self.subgoal_reach_m))
        object.__setattr__(self, "planning_iterations", int(self.planning_iterations))
        object.__setattr__(self, "block_walls", bool(self.block_walls))

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The settings' names, in file order."""
        return tuple(field.name for field in dataclasses.fields(cls))

    @classmethod
    def for_body(cls, body: str | None, geometry: MazeGeometry) -> LearnerSettings:
        """The settings :meth:`HighLevelPolicy.for_env` gives a body's learner unless told otherwise.

        Read from the body's profile (``learner_head``, ``learner_plans`` in
        :data:`~antmaze_hirl.envs.profiles.BODY_PROFILES`); ``None`` (an env that names no body): the defaults.
        Both bodies get the next-cell head. The point's reads it out of value iteration that rules out moves
        the walls block, with ``rows + cols + 2`` rounds: a strong prior, which solves most mazes before any
        label (protocol 2 trains ``experiments.config.PROTOCOL_LEARNER``, the CNN head, instead; pass
        ``planning_iterations=0, block_walls=False`` for it). The ant's is the CNN's. How each was chosen, with
        its figures: ``docs/results/learner-ablation.md``.

        Raises:
            ValueError: For a body without a profile (names it and the known ones).
        """
        if body is None:
            return cls()
        if body not in BODY_PROFILES:
            raise ValueError(f"unknown body {body!r}; choose from {sorted(BODY_PROFILES)}")
        profile = BODY_PROFILES[body]
        if profile.learner_plans:
            rounds = planning_rounds(geometry.n_rows, geometry.n_cols)
            return cls(head=profile.learner_head, planning_iterations=rounds, block_walls=True)
        return cls(head=profile.learner_head)

    def replace(self, **changes: Any) -> LearnerSettings:
        """These settings with ``changes`` (field names) applied, checked together.

        Raises:
            ValueError: For a name that is not a setting (names it and the settings), or as the constructor.
        """
        unknown = sorted(set(changes) - set(self.names()))
        if unknown:
            raise ValueError(f"unknown learner settings {unknown}; choose from {list(self.names())}")
        return dataclasses.replace(self, **changes)


class EncodingCache:
    """The network inputs of a dataset's rows, encoded once per row.

    Keyed by the dataset's stable row ids, which removal never reuses, so entries stay right after
    labels are removed; a different dataset starts the cache afresh.
    """

    def __init__(self) -> None:
        self._dataset_key: str | None = None
        self._rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def encoded(
        self, encoder: ObservationEncoder, dataset: DemonstrationDataset, indices: np.ndarray | None
    ) -> EncodedBatch:
        """Encodings of the dataset's rows (or of the positions ``indices``, repeats allowed).

        Raises:
            ValueError: If the dataset is empty.
        """
        if len(dataset) == 0:
            raise ValueError("the dataset is empty")
        if self._dataset_key != dataset.key:
            self._dataset_key, self._rows = dataset.key, {}
        ids = dataset.ids(indices)
        missing = [int(row) for row in dict.fromkeys(ids.tolist()) if row not in self._rows]
        if missing:
            new = encoder.encode_observations(dataset.observations_by_id(missing))
            self._rows.update(zip(missing, zip(new.grids, new.vectors, strict=True), strict=True))
        return EncodedBatch(
            np.stack([self._rows[int(row)][0] for row in ids]), np.stack([self._rows[int(row)][1] for row in ids])
        )


class MoveOutcomes:
    """The moves a learner's training episodes tried and what became of them (``experience_blocking_weight``).

    A row: the encoded observation the move was tried from, its ``(dx, dy)`` cell step, and 1.0 where the move was
    blocked (the walk ended outside the cell it moved towards) or 0.0 where it was made (the walk entered it).
    """

    def __init__(self) -> None:
        self._rows: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]] = []
        self._arrays: tuple[EncodedBatch, np.ndarray, np.ndarray] | None = None

    def __len__(self) -> int:
        return len(self._rows)

    def add(self, batch: EncodedBatch, steps: np.ndarray, blocked: np.ndarray) -> None:
        """Appends one row per sample of ``batch``: its cell step (``(B, 2)``) and whether it was blocked (``(B,)``)."""
        steps, blocked = np.asarray(steps, dtype=np.float32), np.asarray(blocked, dtype=np.float32)
        for row in zip(batch.grids, batch.vectors, steps, blocked, strict=True):
            self._rows.append((row[0], row[1], row[2], float(row[3])))
        self._arrays = None

    def arrays(self) -> tuple[EncodedBatch, np.ndarray, np.ndarray]:
        """Every row stacked: the encodings, the cell steps ``(N, 2)`` and the blocked flags ``(N,)``."""
        if self._arrays is None:
            grids, vectors, steps, blocked = zip(*self._rows, strict=True)
            self._arrays = (
                EncodedBatch(np.stack(grids), np.stack(vectors)),
                np.stack(steps),
                np.asarray(blocked, dtype=np.float32),
            )
        return self._arrays


class HighLevelPolicy:
    """The high-level learner of :class:`~antmaze_hirl.dagger.DAggerTrainer`: subgoals from a network it fits.

    It maps observations to xy subgoals, ``agent_xy + subgoal_reach_m * network(encoding)``, and trains
    :attr:`network` with Adam on the expert's subgoals: heading cross-entropy plus squared distance error
    (``"heading"``), or cross-entropy over the cell each label's subgoal lies in (``"next_cell"``), with random
    symmetries of the square as augmentation.

    Args:
        geometry: Map placement of the env it acts in.
        pixels_per_cell: The env's image resolution.
        body_dim: Length of the body observation in the env's ``state``.
        rng: Seeds the network initialisation (one draw), then draws minibatches and augmentations; torch's
            global RNG is left as it was.
        settings: The network's shape and training (:class:`LearnerSettings`; ``None``: the defaults).
            A ``subgoal_reach_m`` of ``None`` becomes one cell of ``geometry``.

    Attributes:
        settings: The settings, ``subgoal_reach_m`` resolved to metres.
        network: The torch module: a :class:`~antmaze_hirl.dagger.network.SubgoalNetwork` (``"heading"``) or a
            :class:`~antmaze_hirl.dagger.network.NextCellNetwork` (``"next_cell"``).
        encoder: Turns observations into the network's inputs.
        gradient_steps: Gradient steps taken so far.
        outcomes: The moves its training episodes tried and their outcomes (:meth:`observe_step`; kept only with
            ``experience_blocking_weight``, not saved).
    """

    def __init__(
        self,
        geometry: MazeGeometry,
        *,
        pixels_per_cell: int,
        body_dim: int,
        rng: np.random.Generator,
        settings: LearnerSettings | None = None,
    ) -> None:
        settings = settings if settings is not None else LearnerSettings()
        if settings.subgoal_reach_m is None:
            settings = settings.replace(subgoal_reach_m=geometry.scale)
        self.geometry = geometry
        self.pixels_per_cell = pixels_per_cell
        self.body_dim = body_dim
        self.settings = settings
        self.rng = rng
        self.encoder = ObservationEncoder(geometry, pixels_per_cell)
        vector_dim = STATE_LAYOUT.state_dim(body_dim)
        with th.random.fork_rng(devices=[]):  # seed the initialisation without touching torch's global RNG
            th.manual_seed(int(rng.integers(2**31)))
            if settings.head == "next_cell":
                self.network: nn.Module = NextCellNetwork(
                    self.encoder.grid_size,
                    vector_dim,
                    settings.channels,
                    settings.hidden,
                    settings.planning_iterations,
                    block_walls=settings.block_walls,
                    any_map=settings.any_map,
                    learnt_blocking=settings.learnt_blocking,
                    binary_blocking=settings.binary_blocking,
                    cell_blocking=settings.cell_switch,
                )
            else:
                self.network = SubgoalNetwork(
                    self.encoder.grid_size,
                    vector_dim,
                    settings.n_directions,
                    settings.channels,
                    settings.hidden,
                    settings.planning_iterations,
                )
        # foreach: one kernel per update op over all tensors instead of a loop of small ones; the same
        # elementwise math, so the same weights bit for bit (benchmarks/trial_speed.py checks a trial's outcomes).
        # ZeroSafeAdam is that step without torch's slow root of exact zeros, again the same weights bit for bit.
        self.optimizer = ZeroSafeAdam(self.network.parameters(), lr=settings.learning_rate, foreach=True)
        self.gradient_steps = 0
        self.cache = EncodingCache()
        self.outcomes = MoveOutcomes()

    @classmethod
    def for_env(cls, env: Any, *, rng: np.random.Generator, **overrides: Any) -> HighLevelPolicy:
        """A learner shaped for a (wrapped) high-level env, with its body's settings (:meth:`LearnerSettings.for_body`).

        ``overrides`` (:class:`LearnerSettings` fields) replace those (``head="heading", planning_iterations=0,
        block_walls=False`` for the point's previous default).

        Raises:
            ValueError: For an unknown setting or a bad value (:meth:`LearnerSettings.replace`).
            TypeError: If ``env`` is not a high-level maze env (:func:`~antmaze_hirl.envs.protocol.maze_env`).
        """
        maze = maze_env(env)
        settings = LearnerSettings.for_body(maze.body, maze.geometry).replace(**overrides)
        return cls(
            maze.geometry,
            pixels_per_cell=maze.pixels_per_cell,
            body_dim=STATE_LAYOUT.body_dim(maze.observation_space["state"].shape[0]),
            rng=rng,
            settings=settings,
        )

    @property
    def subgoal_reach_m(self) -> float:
        """Farthest subgoal from the agent, metres (``settings.subgoal_reach_m``, resolved)."""
        reach = self.settings.subgoal_reach_m
        assert reach is not None  # resolved in __init__
        return reach

    @property
    def planar_feature_dim(self) -> int:
        """Leading encoded features that turn with the maze (xy pairs): goal and in-cell offsets, and a 2-D body state.

        The point's velocity is such a body state; the ant's is not. :func:`~antmaze_hirl.dagger.features.augment`
        and the symmetric views turn these features.
        """
        return OFFSET_FEATURE_DIM + (2 if self.body_dim == 2 else 0)

    def offsets(self, batch: EncodedBatch) -> np.ndarray:
        """Normalised offsets (``[-1, 1]^2``) for an encoded batch."""
        self.network.eval()
        with th.no_grad():
            outputs = self.network(th.from_numpy(batch.grids), th.from_numpy(batch.vectors))
        if self.settings.head == "next_cell":
            return self.cell_offsets(batch, outputs.argmax(dim=1).numpy())
        return offsets_from_outputs(*outputs).numpy().astype(np.float64)

    def cell_offsets(self, batch: EncodedBatch, classes: np.ndarray) -> np.ndarray:
        """Normalised offsets to the chosen next cells: each cell's centre, or the goal where it lies there.

        Everything comes from the encoding: the in-cell and goal offsets from the vector, the goal's
        cell from the grid's goal channel (the agent's cell is the grid's centre).
        """
        steps = np.asarray(NEXT_CELL_MOVES, dtype=np.float64)[classes]
        in_cell, to_goal = batch.vectors[:, 2:4].astype(np.float64), batch.vectors[:, 0:2].astype(np.float64)
        centre = batch.grids.shape[-1] // 2
        rows, cols = centre - steps[:, 1].astype(int), centre + steps[:, 0].astype(int)
        holds_goal = batch.grids[np.arange(len(batch)), 1, rows, cols] > 0.5
        offsets = np.where(holds_goal[:, None], to_goal, steps - in_cell) * self.geometry.scale
        lengths = np.linalg.norm(offsets, axis=1, keepdims=True)
        offsets = offsets * np.minimum(1.0, self.subgoal_reach_m / np.maximum(lengths, 1e-12))  # the oracle's reach
        return offsets / self.subgoal_reach_m

    def cell_steps(self, agent_xy: np.ndarray, subgoals: np.ndarray) -> np.ndarray:
        """The ``(dx, dy)`` cell step from each agent's cell to its subgoal's, clipped to ``{-1, 0, 1}^2``.

        The agent's cell is clipped to the map as the encoder clips it (a body pressed into the border).
        Where the reach (``subgoal_reach_m``) is shorter than a cell, a subgoal at the reach (at least
        :data:`AT_REACH` of it) points on along the path: it is carried one cell side from the agent
        before its cell is read. Without that, the ant's 2 m subgoals (half a 4 m cell) from an agent
        near its cell's centre end in its own cell, and most of the oracle's labels on ant mazes
        would teach "stay" (docs/results/learner-ablation.md, ``scripts/next_cell_labels.py``).
        """
        agent_xy, subgoals = np.asarray(agent_xy, dtype=np.float64), np.asarray(subgoals, dtype=np.float64)
        if self.subgoal_reach_m < self.geometry.scale:
            offsets = subgoals - agent_xy
            lengths = np.linalg.norm(offsets, axis=1, keepdims=True)
            at_reach = lengths >= AT_REACH * self.subgoal_reach_m
            carried = agent_xy + offsets * (self.geometry.scale / np.maximum(lengths, 1e-12))
            subgoals = np.where(at_reach, carried, subgoals)
        last = np.array([self.geometry.n_rows - 1, self.geometry.n_cols - 1])
        agent = np.clip([self.geometry.xy_to_cell(xy) for xy in agent_xy], 0, last)
        target = np.clip([self.geometry.xy_to_cell(xy) for xy in subgoals], 0, last)
        rows, cols = (target - agent).T
        return np.clip(np.stack([cols, -rows], axis=1), -1, 1).astype(np.float32)

    def predict_batch(self, observations: list[dict[str, np.ndarray]]) -> np.ndarray:
        """Subgoals (metres) for a list of observations."""
        agents = np.stack([np.asarray(STATE_LAYOUT.agent_xy(obs["state"]), dtype=np.float64) for obs in observations])
        return agents + self.subgoal_reach_m * self.offsets(self.encoder.encode_observations(observations))

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The subgoal (metres) for one observation."""
        return self.predict_batch([observation])[0]

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Same as :meth:`predict`, so the learner serves as an expert-like callable."""
        return self.predict(observation)

    def observe_step(self, observation: dict[str, np.ndarray], subgoal: np.ndarray, info: dict[str, Any]) -> None:
        """Records what became of a high-level step its trainer executed (``experience_blocking_weight`` only).

        The move is the cell step to ``subgoal``'s cell (:meth:`cell_steps`, as a label's). It was made if the
        walk (``info["agent_path"]``) entered the cell moved towards; blocked if it did not and the walk ended
        without reaching the subgoal, without a fall (``flipped``) and without the goal. Anything else (a stay,
        a subgoal reached short of the cell, a fall) is not recorded. Nothing is recorded, and nothing drawn,
        when the weight is 0.

        Args:
            observation: The high-level observation the step started from.
            subgoal: The subgoal the env executed, metres.
            info: The env's step info (``agent_path``, ``subgoal_reached``, ``flipped``, ``is_success``).
        """
        if not self.settings.experience_blocking_weight:
            return
        agent_xy = np.asarray(STATE_LAYOUT.agent_xy(observation["state"]), dtype=np.float64)
        step = self.cell_steps(agent_xy[None], np.asarray(subgoal, dtype=np.float64)[None])[0]
        if not step.any():
            return
        last = np.array([self.geometry.n_rows - 1, self.geometry.n_cols - 1])
        target = np.clip(self.geometry.xy_to_cell(agent_xy), 0, last) + np.array([-int(step[1]), int(step[0])])
        cells = np.clip([self.geometry.xy_to_cell(xy) for xy in np.asarray(info["agent_path"])], 0, last)
        entered = bool((cells == target).all(axis=1).any())
        if not entered and (info["subgoal_reached"] or info["flipped"] or info["is_success"]):
            return
        self.outcomes.add(self.encoder.encode_observations([observation]), step[None], np.array([not entered]))

    def targets(self, agent_xy: np.ndarray, subgoals: np.ndarray) -> np.ndarray:
        """Training targets: expert offsets in units of ``subgoal_reach_m``, shortened to length 1 at most.

        With the ``"next_cell"`` head: the ``(dx, dy)`` cell steps to the labels' cells (:meth:`cell_steps`),
        which the square's symmetries map as they map xy offsets.
        """
        if self.settings.head == "next_cell":
            return self.cell_steps(agent_xy, subgoals)
        offsets = (subgoals - agent_xy) / self.subgoal_reach_m
        lengths = np.linalg.norm(offsets, axis=1, keepdims=True)
        return (offsets / np.maximum(lengths, 1.0)).astype(np.float32)

    def fit(self, batch: EncodedBatch, targets: np.ndarray, steps: int) -> float:
        """Runs ``steps`` Adam steps on minibatches of ``batch`` and its :meth:`targets`.

        Returns:
            The mean loss of the last 10 steps (``nan`` if ``steps`` is 0 or the batch is empty).
        """
        if steps <= 0 or len(batch) == 0:
            return float("nan")
        settings, network = self.settings, self.network
        network.train()
        losses = []
        for _ in range(steps):
            index = self.rng.integers(len(batch), size=min(settings.batch_size, len(batch)))
            minibatch = EncodedBatch(batch.grids[index], batch.vectors[index])
            labels = targets[index]
            if settings.augment_symmetries:
                minibatch, labels = augment(minibatch, labels, self.rng, planar_feature_dim=self.planar_feature_dim)
            grids, vectors = th.from_numpy(minibatch.grids), th.from_numpy(minibatch.vectors)
            if settings.switch_flattening != 1.0:
                loss = self._flattened_switch_loss(grids, th.from_numpy(next_cell_classes(labels)))
            elif settings.head == "next_cell":
                # The gate's logits come from the same pass as the move logits: its convolutions run once a step.
                logits, gate_logits = network.logits_and_blocking_logits(grids, vectors)
                loss = nn.functional.cross_entropy(logits, th.from_numpy(next_cell_classes(labels)))
                if settings.blocking_pressure:
                    # -log b = softplus(-logit): the push towards blocked, on every move of every cell
                    loss = loss + settings.blocking_pressure * nn.functional.softplus(-gate_logits).mean()
            else:
                logits, distance = network(grids, vectors)
                bins = th.from_numpy(direction_bins(labels, settings.n_directions))
                lengths = th.from_numpy(np.linalg.norm(labels, axis=1))
                loss = nn.functional.cross_entropy(logits, bins) + th.mean((distance - lengths) ** 2)
            if settings.experience_blocking_weight and len(self.outcomes):
                loss = loss + settings.experience_blocking_weight * self._experience_loss()
            self.optimizer.zero_grad()
            loss.backward()
            self.optimizer.step()
            losses.append(loss.item())
        self.gradient_steps += steps
        return float(np.mean(losses[-10:]))

    def _experience_loss(self) -> th.Tensor:
        """A minibatch's logistic loss of the tried moves' switch logits against their outcomes (1: blocked).

        The logit read is the switch the value iteration applies to that move from the agent's cell: the move's
        own at the grid centre, or with ``cell_switch`` the destination cell's. Symmetries as for the labels.
        """
        batch, steps, blocked = self.outcomes.arrays()
        index = self.rng.integers(len(blocked), size=min(self.settings.batch_size, len(blocked)))
        minibatch, steps = EncodedBatch(batch.grids[index], batch.vectors[index]), steps[index]
        if self.settings.augment_symmetries:
            minibatch, steps = augment(minibatch, steps, self.rng, planar_feature_dim=self.planar_feature_dim)
        logits = self.network.planner.blocking_logits(th.from_numpy(minibatch.grids))
        centre, rows = logits.shape[-1] // 2, th.arange(len(index))
        moves = np.rint(steps).astype(np.int64)
        if self.settings.cell_switch:
            tried = logits[rows, 0, th.from_numpy(centre - moves[:, 1]), th.from_numpy(centre + moves[:, 0])]
        else:
            tried = logits[rows, th.from_numpy(next_cell_classes(steps)), centre, centre]
        return nn.functional.binary_cross_entropy_with_logits(tried, th.from_numpy(blocked[index]))

    def _flattened_switch_loss(self, grids: th.Tensor, classes: th.Tensor) -> th.Tensor:
        """The labels' cross-entropy with the switch learning from a flatter softmax (``switch_flattening``).

        The trust and the costs learn from the logits' own cross-entropy, the switch not; the switch learns from
        a second one over ``switch_flattening * trust * relative - switch`` (trust and Q held), in which a move
        the learnt costs have priced a few moves out still has weight, so it is still pushed towards shut.
        """
        relative, switch = self.network.switch_readout(grids)
        trust = self.network.trust
        loss = nn.functional.cross_entropy(trust * relative - switch.detach(), classes)
        flat = self.settings.switch_flattening * trust.detach() * relative.detach() - switch
        return loss + nn.functional.cross_entropy(flat, classes)

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int, indices: np.ndarray | None = None) -> float:
        """Runs :meth:`fit` on the dataset's labels (or the positions ``indices``, repeats allowed).

        Raises:
            ValueError: If the dataset is empty.
        """
        targets = self.targets(dataset.agent_xy(indices), dataset.subgoals(indices))
        return self.fit(self.cache.encoded(self.encoder, dataset, indices), targets, steps)

    def spawn(self, rng: np.random.Generator) -> HighLevelPolicy:
        """A fresh, untrained learner of the same settings, initialised from ``rng`` (an ensemble member)."""
        return HighLevelPolicy(
            self.geometry, pixels_per_cell=self.pixels_per_cell, body_dim=self.body_dim, rng=rng, settings=self.settings
        )

    @property
    def runs_on_any_map(self) -> bool:
        """Whether the same weights act on a map of any size (:meth:`on_map`): ``settings.any_map``.

        The CNN heads end in a fully connected layer over the whole grid. The earlier planning heads take any
        grid, but their correction reads the goal offset, which grows with the map beyond anything trained on
        (zero-shot on ``large``, grid-level: 56% against the ``any_map`` learner's 91%, medians of 3 seeds in
        ``results/planning_learner/``), so they are not moved either.
        """
        return self.settings.any_map

    def on_map(
        self, geometry: MazeGeometry, *, pixels_per_cell: int | None = None, rng: np.random.Generator | None = None
    ) -> HighLevelPolicy:
        """This learner's weights acting on another map (zero-shot), with planning rounds for that map.

        An ``any_map`` learner (:attr:`runs_on_any_map`) gets :func:`planning_rounds` of ``geometry``; any
        other moves only to a map whose agent-centred grid has its own size.

        Args:
            geometry: The other map's placement; its cell side must be this learner's (the same body).
            pixels_per_cell: The other env's image resolution (default: this learner's).
            rng: The new learner's generator, if it trains on (default seed 0).

        Raises:
            ValueError: Naming both values, if the cell sides differ or a CNN learner's grid does not fit.
        """
        if geometry.scale != self.geometry.scale:
            raise ValueError(
                f"the map's cells are {geometry.scale} m but this learner's are {self.geometry.scale} m: another body"
            )
        settings = self.settings
        if self.runs_on_any_map:
            settings = settings.replace(planning_iterations=planning_rounds(geometry.n_rows, geometry.n_cols))
        else:
            size = 2 * max(geometry.n_rows, geometry.n_cols) - 1
            if size != self.encoder.grid_size:
                raise ValueError(
                    f"this learner (head {self.settings.head!r}, any_map False) sees a {self.encoder.grid_size}x"
                    f"{self.encoder.grid_size} grid and cannot act on a {geometry.n_rows}x{geometry.n_cols} map "
                    f"(a {size}x{size} grid); only an any_map planning learner runs on any map"
                )
        moved = HighLevelPolicy(
            geometry,
            pixels_per_cell=pixels_per_cell if pixels_per_cell is not None else self.pixels_per_cell,
            body_dim=self.body_dim,
            rng=rng if rng is not None else np.random.default_rng(0),
            settings=settings,
        )
        moved.network.load_state_dict(self.network.state_dict())
        return moved

    def config(self) -> dict[str, Any]:
        """What a saved file's ``config`` holds, by Python name.

        The env's shape (:data:`ENV_SHAPE_KEYS`, ``geometry`` as ``[rows, cols, scale]``), then the
        :class:`LearnerSettings` fields.
        """
        shape = [self.geometry.n_rows, self.geometry.n_cols, self.geometry.scale]
        return {
            "geometry": shape,
            "pixels_per_cell": self.pixels_per_cell,
            "body_dim": self.body_dim,
            **dataclasses.asdict(self.settings),
        }

    def save(self, path: str | Path) -> Path:
        """Saves :meth:`config` and the weights to a zip (format :data:`FORMAT`), atomically (temp file + rename)."""
        config = {FILE_KEYS.get(key, key): value for key, value in self.config().items()}
        weights = io.BytesIO()
        th.save(self.network.state_dict(), weights)
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w") as archive:
            archive.writestr("meta.json", json.dumps({"format": FORMAT, "config": config}))
            archive.writestr("weights.pt", weights.getvalue())
        return atomic_write_bytes(path, buffer.getvalue())

    @classmethod
    def load(cls, path: str | Path, *, rng: np.random.Generator | None = None) -> HighLevelPolicy:
        """Loads a learner written by :meth:`save` (by any 0.x version); ``rng`` (default seed 0) trains it on.

        Settings a file lacks (older files) take the :class:`LearnerSettings` defaults.

        Raises:
            FileNotFoundError: If ``path`` does not exist.
            ValueError: If the file is not a high-level policy of this format, or holds settings or weights
                this version cannot load (names what is wrong).
        """
        config, weights = read_policy_file(path)
        unknown = sorted(set(config) - {*ENV_SHAPE_KEYS, *LearnerSettings.names()})
        if unknown:
            raise ValueError(f"{path} holds settings this version cannot load: unknown {unknown}")
        try:
            settings = LearnerSettings(**{key: config[key] for key in LearnerSettings.names() if key in config})
            learner = cls(
                MazeGeometry(*config["geometry"]),
                pixels_per_cell=config["pixels_per_cell"],
                body_dim=config["body_dim"],
                rng=rng if rng is not None else np.random.default_rng(0),
                settings=settings,
            )
            learner.network.load_state_dict(th.load(io.BytesIO(weights), weights_only=True))
        except (KeyError, TypeError, ValueError, RuntimeError) as error:
            raise ValueError(f"{path} holds settings or weights this version cannot load: {error}") from error
        return learner


def read_policy_file(path: str | Path) -> tuple[dict[str, Any], bytes]:
    """The ``config`` (keyed by Python names, :data:`FILE_KEYS` translated) and weight bytes of a policy zip.

    Raises:
        FileNotFoundError: If ``path`` does not exist.
        ValueError: If the file is not a high-level policy of format :data:`FORMAT`.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no high-level policy at {path}")
    try:
        with zipfile.ZipFile(path) as archive:
            meta = json.loads(archive.read("meta.json"))
            weights = archive.read("weights.pt")
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError) as error:
        raise ValueError(f"{path} is not a high-level policy file: {error}") from error
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else None
        raise ValueError(f"{path} has format {found!r}, expected {FORMAT!r}")
    try:
        stored = dict(meta["config"])
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path} holds settings this version cannot load: {error}") from error
    names = {key: name for name, key in FILE_KEYS.items()}
    return {names.get(key, key): value for key, value in stored.items()}, weights
