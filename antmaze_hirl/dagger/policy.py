"""The high-level policy: an ``nn.Module`` mapping observations to xy subgoals, with zip persistence.

Training lives in :mod:`antmaze_hirl.dagger.learner`; :class:`HighLevelPolicy`, the two together,
lives in :mod:`antmaze_hirl.dagger.high_level_policy` and is still importable from here.
"""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from torch import nn

from antmaze_hirl.atomic_io import atomic_write_bytes
from antmaze_hirl.dagger.features import OFFSET_FEATURE_DIM, EncodedBatch, ObservationEncoder
from antmaze_hirl.dagger.network import (
    NEXT_CELL_MOVES,
    NextCellNetwork,
    SubgoalNetwork,
    offsets_from_outputs,
)
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.state_layout import STATE_LAYOUT

FORMAT = "antmaze_hirl.high_level_policy/2"

HEADS = ("heading", "next_cell")
"""What the network outputs: a free heading and distance, or the next cell of the path (3x3 around the agent)."""

POLICY_SETTINGS = (
    "pixels_per_cell",
    "body_dim",
    "subgoal_reach_m",
    "n_directions",
    "planning_iterations",
    "channels",
    "hidden",
    "head",
    "block_walls",
)
"""The :class:`SubgoalPolicy` constructor settings stored in a zip's ``config`` (besides ``geometry``)."""

FILE_KEYS = {"subgoal_reach_m": "max_offset"}
"""Settings a zip's ``config`` stores under another key: format 2 predates the 0.2.0 names, and the committed
and shipped files keep reading only if the key in the file stays (:meth:`SubgoalPolicy.save`,
:func:`read_policy_file` translate)."""

AT_REACH = 0.9
"""Share of ``subgoal_reach_m`` from which a label counts as cut short at the reach (the oracle's are exactly at it;
a noisy or human click a little short of it still points past it)."""


class SubgoalPolicy(nn.Module):
    """Maps high-level observations to xy subgoals: ``agent_xy + subgoal_reach_m * network(encoding)``.

    Args:
        geometry: Map placement of the env it acts in.
        pixels_per_cell: The env's image resolution.
        body_dim: Length of the body observation in the env's ``state``.
        rng: Seeds the network initialisation (one draw; torch's global RNG is left as it was).
        subgoal_reach_m: Farthest subgoal from the agent, metres. Default one cell (the oracle's default reach;
            the experiment passes its oracle's ``expert_max_distance``, the ant's 2 m).
        n_directions: Heading bins of the network (a positive multiple of 4).
        planning_iterations: Value-iteration rounds (0, the default: CNN only). With the heading head,
            value-iteration features beside the CNN's (on 5x5 point mazes they did not beat the CNN within
            30 episodes: 70% vs 70% learner-only success on 20 mazes); with the next-cell head, the planner
            whose Q gives the logits, which needs at least the longest path's moves
            (``HighLevelPolicy.for_env`` gives the point ``rows + cols + 2``).
        channels: Convolution channels.
        hidden: Width of the fully connected layers.
        head: ``"heading"`` (this class's default; ``HighLevelPolicy.for_env`` picks per body): classify a
            heading among ``n_directions`` and regress a distance. ``"next_cell"``: classify which of the 3x3
            cells around the agent's cell comes next on the path (a label's class is the cell its subgoal lies
            in); the subgoal is that cell's centre, or the goal where the goal lies in it, pulled back to
            ``subgoal_reach_m``. With ``planning_iterations > 0`` its logits are a value iteration network's Q at the
            agent's cell.
        block_walls: With the ``"next_cell"`` head's value iteration: moves into a wall, or diagonally
            between two, are ruled out (the walls read from the image). Needs ``planning_iterations > 0``.

    Raises:
        ValueError: If ``n_directions`` is not a positive multiple of 4, ``head`` is unknown, or
            ``planning_iterations`` is negative, or ``block_walls`` is set without the planning next-cell head.
    """

    def __init__(
        self,
        geometry: MazeGeometry,
        *,
        pixels_per_cell: int,
        body_dim: int,
        rng: np.random.Generator,
        subgoal_reach_m: float | None = None,
        n_directions: int = 16,
        planning_iterations: int = 0,
        channels: int = 16,
        hidden: int = 128,
        head: str = "heading",
        block_walls: bool = False,
    ) -> None:
        super().__init__()
        if n_directions < 4 or n_directions % 4:
            raise ValueError(f"n_directions must be a positive multiple of 4, got {n_directions}")
        if head not in HEADS:
            raise ValueError(f"head must be one of {list(HEADS)}, got {head!r}")
        if planning_iterations < 0:
            raise ValueError(f"planning_iterations must be >= 0, got {planning_iterations}")
        if block_walls and (head != "next_cell" or planning_iterations == 0):
            raise ValueError("block_walls needs head='next_cell' and planning_iterations > 0")
        self.geometry = geometry
        self.pixels_per_cell = pixels_per_cell
        self.body_dim = body_dim
        self.subgoal_reach_m = float(subgoal_reach_m if subgoal_reach_m is not None else geometry.scale)
        self.n_directions = n_directions
        self.planning_iterations = int(planning_iterations)
        self.channels = channels
        self.hidden = hidden
        self.head = head
        self.block_walls = bool(block_walls)
        self.encoder = ObservationEncoder(geometry, pixels_per_cell)
        vector_dim = STATE_LAYOUT.state_dim(body_dim)
        with th.random.fork_rng(devices=[]):  # seed the initialisation without touching torch's global RNG
            th.manual_seed(int(rng.integers(2**31)))
            if head == "next_cell":
                self.network: nn.Module = NextCellNetwork(
                    self.encoder.grid_size,
                    vector_dim,
                    channels,
                    hidden,
                    self.planning_iterations,
                    block_walls=self.block_walls,
                )
            else:
                self.network = SubgoalNetwork(
                    self.encoder.grid_size, vector_dim, n_directions, channels, hidden, self.planning_iterations
                )

    @property
    def planar_feature_dim(self) -> int:
        """Leading encoded features that turn with the maze (xy pairs): goal and in-cell offsets, and a 2-D body state.

        The point's velocity is such a body state; the ant's is not. :func:`~antmaze_hirl.dagger.features.augment`
        and the symmetric views turn these features.
        """
        return OFFSET_FEATURE_DIM + (2 if self.body_dim == 2 else 0)

    def forward(self, grids: th.Tensor, vectors: th.Tensor) -> Any:
        """The network's outputs for an encoded batch.

        ``"heading"``: heading logits ``(B, n_directions)`` and distances ``(B,)``; ``"next_cell"``:
        logits ``(B, 9)`` over :data:`~antmaze_hirl.dagger.network.NEXT_CELL_MOVES`.
        """
        return self.network(grids, vectors)

    def offsets(self, batch: EncodedBatch) -> np.ndarray:
        """Normalised offsets (``[-1, 1]^2``) for an encoded batch."""
        self.network.eval()
        with th.no_grad():
            outputs = self.network(th.from_numpy(batch.grids), th.from_numpy(batch.vectors))
        if self.head == "next_cell":
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
        near its cell's centre end in its own cell, and 58% of the oracle's labels on 4x4 ant mazes
        would teach "stay" (``scripts/next_cell_labels.py``).
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

    def config(self) -> dict[str, Any]:
        """Constructor settings (``geometry`` as ``[rows, cols, scale]``), stored with saved weights."""
        return {
            "geometry": [self.geometry.n_rows, self.geometry.n_cols, self.geometry.scale],
            "pixels_per_cell": self.pixels_per_cell,
            "body_dim": self.body_dim,
            "subgoal_reach_m": self.subgoal_reach_m,
            "n_directions": self.n_directions,
            "planning_iterations": self.planning_iterations,
            "channels": self.channels,
            "hidden": self.hidden,
            "head": self.head,
            "block_walls": self.block_walls,
        }

    def save(self, path: str | Path, *, learner_config: Mapping[str, Any] | None = None) -> Path:
        """Saves settings and weights to a zip, atomically (temp file + rename).

        Args:
            path: Destination file.
            learner_config: Training settings stored alongside (what :class:`HighLevelPolicy` reloads).
        """
        settings = {**self.config(), **(learner_config or {})}
        config = {FILE_KEYS.get(key, key): value for key, value in settings.items()}
        weights = io.BytesIO()
        th.save(self.network.state_dict(), weights)
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w") as archive:
            archive.writestr("meta.json", json.dumps({"format": FORMAT, "config": config}))
            archive.writestr("weights.pt", weights.getvalue())
        return atomic_write_bytes(path, buffer.getvalue())

    @classmethod
    def load(cls, path: str | Path, *, rng: np.random.Generator | None = None) -> SubgoalPolicy:
        """Loads a policy written by :meth:`save` (or by :class:`HighLevelPolicy`), ignoring training settings.

        Raises:
            FileNotFoundError: If ``path`` does not exist.
            ValueError: If the file is not a high-level policy of this format (names what is wrong).
        """
        config, weights = read_policy_file(path)
        return cls.from_file_contents(path, config, weights, rng)

    @classmethod
    def from_file_contents(
        cls, path: str | Path, config: dict[str, Any], weights: bytes, rng: np.random.Generator | None
    ) -> SubgoalPolicy:
        """The policy of a file's ``config`` (its policy settings) and weights; ``path`` names it in errors.

        Raises:
            ValueError: If the settings or weights do not fit this version.
        """
        try:
            settings = {key: config[key] for key in POLICY_SETTINGS if key in config}
            geometry = MazeGeometry(*config["geometry"])
            policy = cls(geometry, rng=rng if rng is not None else np.random.default_rng(0), **settings)
            policy.network.load_state_dict(th.load(io.BytesIO(weights), weights_only=True))
        except (KeyError, TypeError, RuntimeError) as error:
            raise ValueError(f"{path} holds settings or weights this version cannot load: {error}") from error
        return policy


def read_policy_file(path: str | Path) -> tuple[dict[str, Any], bytes]:
    """The ``config`` (keyed by constructor names, :data:`FILE_KEYS` translated) and weight bytes of a policy zip.

    Raises:
        FileNotFoundError: If ``path`` does not exist.
        ValueError: If the file is not a high-level policy of format ``antmaze_hirl.high_level_policy/2``.
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


def __getattr__(name: str) -> Any:
    # HighLevelPolicy moved to its own module (it imports this one); importing it lazily avoids a cycle.
    if name == "HighLevelPolicy":
        from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy

        return HighLevelPolicy
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
