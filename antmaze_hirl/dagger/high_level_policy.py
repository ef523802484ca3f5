""":class:`HighLevelPolicy`: a :class:`SubgoalPolicy` with its :class:`SubgoalLearner`, the DAgger learner."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import EncodedBatch, ObservationEncoder
from antmaze_hirl.dagger.learner import LEARNER_SETTINGS, SubgoalLearner
from antmaze_hirl.dagger.policy import POLICY_SETTINGS, SubgoalPolicy, read_policy_file
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.profiles import BODY_PROFILES
from antmaze_hirl.envs.state_layout import STATE_LAYOUT


def planning_rounds(n_rows: int, n_cols: int) -> int:
    """Value-iteration rounds of a planning next-cell head on an ``n_rows x n_cols`` map (border included).

    ``rows + cols + 2``: enough moves for the map's longest shortest path.
    """
    return n_rows + n_cols + 2


def body_policy_defaults(body: str, geometry: MazeGeometry) -> dict[str, Any]:
    """The settings :meth:`HighLevelPolicy.for_env` gives a body's policy unless told otherwise.

    Both bodies get the next-cell head, each the winner of ``scripts/learner_ablation.py`` on its
    held-out mazes' selection part. The point's reads it out of value iteration that rules out moves the walls
    block, with ``rows + cols + 2`` rounds (16 on the 7x7 map of its 5x5 mazes, whose longest shortest
    path is 15 moves; ``results/learner_ablation/learner_ablation.json``). The ant's is the CNN's: on its 4x4
    mazes it tied value iteration on the selection mazes' median and costs 28% less time, and ruling out
    wall moves lost there, since its 2 m labels cut corners the cell grid calls walls
    (``results/learner_ablation/learner_ablation_ant.json``). The ant's heading head, its default before,
    scored 52% against 77%.
    """
    profile = BODY_PROFILES.get(body)
    if profile is None:
        return {}
    if profile.learner_plans:
        return {
            "head": profile.learner_head,
            "planning_iterations": planning_rounds(geometry.n_rows, geometry.n_cols),
            "block_walls": True,
        }
    return {"head": profile.learner_head}


class HighLevelPolicy:
    """The high-level learner of :class:`~antmaze_hirl.dagger.DAggerTrainer`: a policy and how it is trained.

    :attr:`policy` (an ``nn.Module``) maps observations to subgoals; :attr:`learner` fits it. This
    object keeps the one-object interface the trainer, the strategies and saved files use.

    Args:
        geometry: Map placement of the env it acts in.
        pixels_per_cell: The env's image resolution.
        body_dim: Length of the body observation in the env's ``state``.
        rng: Seeds the network initialisation, then draws minibatches and augmentations.
        subgoal_reach_m: Farthest subgoal from the agent, metres. Default one cell (the oracle's default reach;
            the experiment passes its oracle's ``expert_max_distance``, the ant's 2 m).
        learning_rate: Adam step size.
        batch_size: Minibatch size of :meth:`fit`.
        augment_symmetries: Train on random rotations/mirrors of each sample.
        n_directions: Heading bins of the network.
        planning_iterations: Value-iteration rounds of an added planning module (0: CNN only).
        channels: Convolution channels.
        hidden: Width of the fully connected layers.
        head: ``"heading"`` or ``"next_cell"`` (:class:`~antmaze_hirl.dagger.policy.SubgoalPolicy`).
        block_walls: The next-cell planner rules out moves the walls block (``SubgoalPolicy``).
    """

    def __init__(
        self,
        geometry: MazeGeometry,
        *,
        pixels_per_cell: int,
        body_dim: int,
        rng: np.random.Generator,
        subgoal_reach_m: float | None = None,
        learning_rate: float = 1e-3,
        batch_size: int = 64,
        augment_symmetries: bool = True,
        n_directions: int = 16,
        planning_iterations: int = 0,
        channels: int = 16,
        hidden: int = 128,
        head: str = "heading",
        block_walls: bool = False,
    ) -> None:
        self.policy = SubgoalPolicy(
            geometry,
            pixels_per_cell=pixels_per_cell,
            body_dim=body_dim,
            rng=rng,
            subgoal_reach_m=subgoal_reach_m,
            n_directions=n_directions,
            planning_iterations=planning_iterations,
            channels=channels,
            hidden=hidden,
            head=head,
            block_walls=block_walls,
        )
        self.learner = SubgoalLearner(
            self.policy,
            rng=rng,
            learning_rate=learning_rate,
            batch_size=batch_size,
            augment_symmetries=augment_symmetries,
        )

    @classmethod
    def for_env(cls, env: Any, *, rng: np.random.Generator, **kwargs: Any) -> HighLevelPolicy:
        """A policy shaped for a (wrapped) high-level env, with its body's defaults (:func:`body_policy_defaults`).

        ``kwargs`` override those defaults (``head="heading", planning_iterations=0, block_walls=False``
        for the point's previous default).
        """
        inner = env.unwrapped
        settings = {**body_policy_defaults(getattr(inner, "body", ""), inner.geometry), **kwargs}
        return cls(
            inner.geometry,
            pixels_per_cell=inner.renderer.pixels_per_cell,
            body_dim=STATE_LAYOUT.body_dim(inner.observation_space["state"].shape[0]),
            rng=rng,
            **settings,
        )

    @property
    def geometry(self) -> MazeGeometry:
        """Map placement of the env it acts in."""
        return self.policy.geometry

    @property
    def encoder(self) -> ObservationEncoder:
        """The policy's observation encoder."""
        return self.policy.encoder

    @property
    def subgoal_reach_m(self) -> float:
        """Farthest subgoal from the agent, metres."""
        return self.policy.subgoal_reach_m

    @property
    def gradient_steps(self) -> int:
        """Gradient steps taken so far."""
        return self.learner.gradient_steps

    def offsets(self, batch: EncodedBatch) -> np.ndarray:
        """Normalised offsets (``[-1, 1]^2``) for an encoded batch."""
        return self.policy.offsets(batch)

    def predict_batch(self, observations: list[dict[str, np.ndarray]]) -> np.ndarray:
        """Subgoals (metres) for a list of observations."""
        return self.policy.predict_batch(observations)

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The subgoal (metres) for one observation."""
        return self.policy.predict(observation)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Same as :meth:`predict`, so the policy serves as an expert-like callable."""
        return self.predict(observation)

    def fit(self, batch: EncodedBatch, targets: np.ndarray, steps: int) -> float:
        """:meth:`SubgoalLearner.fit`: ``steps`` Adam steps; the mean loss of the last 10."""
        return self.learner.fit(batch, targets, steps)

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int, indices: np.ndarray | None = None) -> float:
        """Trains ``steps`` minibatch steps on the dataset's labels (or the positions ``indices``)."""
        return self.learner.fit_dataset(dataset, steps, indices)

    def spawn(self, rng: np.random.Generator) -> HighLevelPolicy:
        """A fresh, untrained learner of the same settings, initialised from ``rng`` (an ensemble member)."""
        settings = self.config()
        del settings["geometry"]  # the object itself, not its [rows, cols, scale] form
        return HighLevelPolicy(self.geometry, rng=rng, **settings)

    def config(self) -> dict[str, Any]:
        """Constructor settings, stored with saved weights."""
        return {**self.policy.config(), **self.learner.config()}

    def save(self, path: str | Path) -> Path:
        """Saves settings and weights to a zip (format ``antmaze_hirl.high_level_policy/2``), atomically."""
        return self.policy.save(path, learner_config=self.learner.config())

    @classmethod
    def load(cls, path: str | Path, *, rng: np.random.Generator | None = None) -> HighLevelPolicy:
        """Loads a policy and its training settings written by :meth:`save`.

        Raises:
            FileNotFoundError: As :meth:`SubgoalPolicy.load`.
            ValueError: As :meth:`SubgoalPolicy.load`, or for a setting this version does not know.
        """
        config, weights = read_policy_file(path)
        unknown = sorted(set(config) - {"geometry", *POLICY_SETTINGS, *LEARNER_SETTINGS})
        if unknown:
            raise ValueError(f"{path} holds settings this version cannot load: unknown {unknown}")
        rng = rng if rng is not None else np.random.default_rng(0)
        loaded = cls.__new__(cls)
        loaded.policy = SubgoalPolicy.from_file_contents(path, config, weights, rng)
        try:
            loaded.learner = SubgoalLearner(
                loaded.policy, rng=rng, **{key: config[key] for key in LEARNER_SETTINGS if key in config}
            )
        except TypeError as error:
            raise ValueError(f"{path} holds settings this version cannot load: {error}") from error
        return loaded
