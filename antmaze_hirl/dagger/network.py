"""The high-level policy's networks: a CNN (optionally with value iteration) that outputs subgoal headings."""

from __future__ import annotations

import numpy as np
import torch as th
from torch import nn


class ValueIterationModule(nn.Module):
    """A value iteration network (Tamar et al., 2016) over the agent-centred grid.

    A learned reward map is propagated by ``iterations`` rounds of ``Q = conv(R) + conv(V)``,
    ``V = max_a Q``: a differentiable shortest-path planner whose weights are shared across positions,
    so what it learns on a few mazes carries over to new layouts. Returns Q in the 3x3 cells around
    the agent (the grid centre).

    Args:
        iterations: Rounds of value propagation (>= the longest path in cells).
        actions: Q channels.
    """

    def __init__(self, iterations: int, actions: int = 8) -> None:
        super().__init__()
        self.iterations = iterations
        self.reward = nn.Sequential(nn.Conv2d(2, 16, 3, padding=1), nn.ReLU(), nn.Conv2d(16, 1, 1))
        self.q_from_reward = nn.Conv2d(1, actions, 3, padding=1, bias=False)
        self.q_from_value = nn.Conv2d(1, actions, 3, padding=1, bias=False)
        self.features_dim = actions * 9

    def forward(self, grids: th.Tensor) -> th.Tensor:
        """Returns ``(B, actions * 9)`` Q-values around the agent."""
        q_reward = self.q_from_reward(self.reward(grids))
        q = q_reward
        for _ in range(self.iterations):
            q = q_reward + self.q_from_value(q.max(dim=1, keepdim=True).values)
        centre = grids.shape[-1] // 2
        return q[:, :, centre - 1 : centre + 2, centre - 1 : centre + 2].flatten(1)


class SubgoalNetwork(nn.Module):
    """CNN (and optionally a value iteration network) over the agent-centred grid, plus an MLP.

    Outputs ``n_directions`` logits over subgoal headings and a distance in ``[0, 1]`` (of the policy's
    ``max_offset``). Classifying the heading, rather than regressing xy, keeps the policy decisive where
    the expert's labels are multimodal (go round a wall left or right): a regressed mean would point
    into the wall with a tiny step, and every such step costs another expert label.

    Args:
        grid_size: Side of the agent-centred grid.
        vector_dim: Length of the feature vector.
        n_directions: Heading bins (a multiple of 4, so the square's symmetries map bins to bins).
        channels: Convolution channels.
        hidden: Width of the fully connected layers.
        planning_iterations: Value-iteration rounds; 0 leaves the planning module out.
    """

    def __init__(
        self,
        grid_size: int,
        vector_dim: int,
        n_directions: int = 16,
        channels: int = 16,
        hidden: int = 128,
        planning_iterations: int = 0,
    ) -> None:
        super().__init__()
        self.conv = nn.Sequential(
            nn.Conv2d(2, channels, 3, padding=1),
            nn.ReLU(),
            nn.Conv2d(channels, channels, 3, padding=1),
            nn.ReLU(),
            nn.Conv2d(channels, channels, 3, padding=1),
            nn.ReLU(),
            nn.Flatten(),
        )
        self.planner = ValueIterationModule(planning_iterations) if planning_iterations > 0 else None
        planner_dim = self.planner.features_dim if self.planner is not None else 0
        self.body = nn.Sequential(
            nn.Linear(channels * grid_size * grid_size + planner_dim + vector_dim, hidden),
            nn.ReLU(),
            nn.Linear(hidden, hidden),
            nn.ReLU(),
        )
        self.direction = nn.Linear(hidden, n_directions)
        self.distance = nn.Sequential(nn.Linear(hidden, 1), nn.Sigmoid())

    def forward(self, grids: th.Tensor, vectors: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """Returns heading logits ``(B, n_directions)`` and distances ``(B,)`` for a batch."""
        features = [self.conv(grids), vectors]
        if self.planner is not None:
            features.insert(1, self.planner(grids))
        hidden = self.body(th.cat(features, dim=1))
        return self.direction(hidden), self.distance(hidden).squeeze(1)


def offsets_from_outputs(logits: th.Tensor, distance: th.Tensor) -> th.Tensor:
    """Normalised xy offsets: the argmax heading, refined by the probability-weighted mean of its two neighbours."""
    n = logits.shape[1]
    angles = th.arange(n, dtype=logits.dtype) * (2 * np.pi / n)
    probabilities = th.softmax(logits, dim=1)
    best = probabilities.argmax(dim=1, keepdim=True)
    neighbours = (best + th.tensor([-1, 0, 1])) % n
    weights = probabilities.gather(1, neighbours)
    unit = th.stack([th.cos(angles[neighbours]), th.sin(angles[neighbours])], dim=2)
    direction = (weights.unsqueeze(2) * unit).sum(dim=1)
    direction = direction / direction.norm(dim=1, keepdim=True).clamp_min(1e-8)
    return direction * distance.unsqueeze(1)


def direction_bins(offsets: np.ndarray, n_directions: int) -> np.ndarray:
    """Index of the heading bin nearest to each xy offset."""
    angles = np.arctan2(offsets[:, 1], offsets[:, 0])
    return np.round(angles / (2 * np.pi / n_directions)).astype(np.int64) % n_directions
