"""The high-level policy's networks: subgoal headings from a CNN, or the next cell of the path from a planner.

:class:`SubgoalNetwork` classifies a free heading (plus a distance); :class:`NextCellNetwork` classifies
which of the 3x3 cells around the agent to walk to next, its logits read straight out of a value
iteration network's Q at the agent's cell (Tamar et al., 2016) when it plans.
"""

from __future__ import annotations

from typing import Any

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
    ``subgoal_reach_m``). Classifying the heading, rather than regressing xy, keeps the policy decisive where
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


NEXT_CELL_MOVES: tuple[tuple[int, int], ...] = tuple((dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1))
"""The classes of :class:`NextCellNetwork`: cell steps ``(dx, dy)`` (``+x`` east, ``+y`` north; ``(0, 0)`` the
agent's own cell), class ``(dy + 1) * 3 + (dx + 1)``."""


def next_cell_classes(steps: np.ndarray) -> np.ndarray:
    """Class index of each ``(dx, dy)`` cell step in ``{-1, 0, 1}^2`` (rounded, then clipped to it)."""
    steps = np.clip(np.rint(np.asarray(steps, dtype=np.float64)), -1, 1).astype(np.int64)
    return (steps[:, 1] + 1) * 3 + (steps[:, 0] + 1)


UNREACHED = -1.0e3
"""Value of a cell the propagation has not reached from the goal (and of everything outside the grid)."""

BLOCKED_COST = 1.0e4
"""Cost of a move the walls rule out (with ``block_walls``): more than any path's, so none is ever taken."""

BLOCKING_START = -9.0
"""Starting logit of the learnt blocking gate (``learnt_blocking``): ``BLOCKED_COST * sigmoid(-9)``, about 1.2, so
the gate starts as one more move cost of a usual size, with a gradient of a usual size (``sigmoid'(-9)`` times
:data:`BLOCKED_COST`, about 1.2), and labels raise it towards :data:`BLOCKED_COST` where a move must not be made."""

BINARY_BLOCKING_START = -1.0
"""Starting logit of the binary blocking gate (``binary_blocking``): below 0, so every move starts open, by about five
times the spread an untrained network's logits have around their bias (so no move starts blocked)."""

SURROGATE_COST = 1.0
"""The binary gate's backward pass (``binary_blocking``, :class:`BlockingSwitch`): the gradient of a cost
``SURROGATE_COST * logit``, a move's usual cost a unit of logit. Linear, not a sigmoid's: a sigmoid's gradient fades
as a gate moves away from 0, and a labelled move whose gate had gone far past 0 would stay blocked."""

REOPENING = 10.0
"""With ``binary_blocking``, how many times steeper the surrogate is on a blocked move than on an open one: a label
reopens its blocked move ten times faster than the moves a label does not make push an open one shut. A gate's view
is local, so one view is a labelled move on one path and an unlabelled one on another: with one slope the two pushes
balanced at the switch and kept about 5% of the labelled moves blocked on the ant's 4x4 labels."""

OPEN_BAND = 3.0
"""With ``binary_blocking``, how far below 0 an open gate's logit is still pushed further open by its labels. Below
it only the push towards shut passes: otherwise the labels drove every open logit down without end (to about -18
in 1,500 steps on the ant's 4x4 labels), moves into walls with them (the gates share their weights), and the wall
moves, priced out by their learnt cost, were no longer pushed back up: only a quarter of the straight moves into a
wall ended blocked. With the band, free moves settle just below it and moves into walls above 0."""

LOGIT_FLOOR = 100.0
"""With ``binary_blocking``, how far below its best move a move's Q reaches the logits (:class:`NextCellNetwork`):
a move whose next cell the switches cut off from the goal is about ``-UNREACHED`` down, which made the trust's
gradient swing by hundreds and held the trust near 0."""


class BlockingSwitch(th.autograd.Function):
    """The binary gate's cost (``binary_blocking``): :data:`BLOCKED_COST` where a logit is above 0, else 0.

    A switch has no gradient; the backward pass is a surrogate's (straight through), that of a cost
    :data:`SURROGATE_COST` times the logit, shaped so that the labels can block and reopen a move but not drift
    it: on a blocked move :data:`REOPENING` times steeper; on an open move whose logit is :data:`OPEN_BAND` or
    more below 0, only the part that pushes it towards blocked passes.
    """

    @staticmethod
    def forward(ctx: Any, logits: th.Tensor) -> th.Tensor:
        """``BLOCKED_COST * 1[logits > 0]``, the logits' shape."""
        ctx.save_for_backward(logits)
        return BLOCKED_COST * (logits > 0).to(logits.dtype)

    @staticmethod
    def backward(ctx: Any, grad: th.Tensor) -> th.Tensor:
        """The surrogate's gradient with respect to the logits (a negative one raises a logit: blocks)."""
        (logits,) = ctx.saved_tensors
        surrogate = SURROGATE_COST * grad
        open_side = th.where(logits > -OPEN_BAND, surrogate, surrogate.clamp(max=0.0))
        return th.where(logits > 0, REOPENING * surrogate, open_side)


def blocked_moves(walls: th.Tensor) -> th.Tensor:
    """``(B, 9, S, S)`` 1.0 where a move leads into a wall (or off the grid) or squeezes between two walls.

    A diagonal whose two orthogonal cells are both walls passes only through the walls' shared corner.
    """
    size = walls.shape[-1]
    ahead = shifted(walls, size, fill=1.0)
    blocked = [ahead[:, index] for index in range(len(NEXT_CELL_MOVES))]
    for index, (dx, dy) in enumerate(NEXT_CELL_MOVES):
        if dx and dy:
            side_x, side_y = NEXT_CELL_MOVES.index((dx, 0)), NEXT_CELL_MOVES.index((0, dy))
            blocked[index] = th.maximum(blocked[index], ahead[:, side_x] * ahead[:, side_y])
    return th.stack(blocked, dim=1)


class CellValueIteration(nn.Module):
    """Value iteration over the agent-centred grid whose actions are the moves to the 3x3 neighbour cells.

    A differentiable Bellman-Ford (a value iteration network, Tamar et al., 2016, with the grid world's
    deterministic moves as its transitions): a convolution turns walls and goal into a learned cost
    ``c_a(s) > 0`` of each move from each cell (walls learn to cost much; the 3x3 view lets a diagonal
    past a wall corner cost more), then ``iterations`` rounds of ``Q_a(s) = V(s + a) - c_a(s)``,
    ``V = max_a Q_a`` with ``V = 0`` held on the goal's cell (the grid's goal channel). The output is
    Q at the agent's cell (the grid centre): one value per move, used as logits. Costs, not rewards, keep
    the values bounded (a learned reward kernel over ~20 rounds blew up in training), and the weights are
    shared across positions, so a shortest-path rule learnt on a few mazes holds on any.

    With ``block_walls`` the walls of the grid also rule moves out (:func:`blocked_moves`: into a wall, or
    diagonally between two), the grid world's known dynamics, so the learned costs need only rank free
    moves: without it, rare wall shapes near the agent were learned too cheap and the point walked into them.

    With ``learnt_blocking`` each move also has a learnt gate ``b_a(s)`` in ``(0, 1)`` (a second convolution
    over the same 3x3 views), and its cost is ``c_a(s) + BLOCKED_COST * b_a(s)``: the learner can learn that a
    move is never made, at a cost above any path's on any map. Without it, a learnt cost only has to exceed
    the detours of the training mazes: on 4x4 ant mazes the learner learnt walls to cost a few moves, and on
    larger maps, where detours are longer, 55 of its 59 grid-level failures on 8x8 selection mazes were moves
    into a wall (``docs/results/planning-learner.md``). Unlike ``block_walls``, nothing is ruled out before a
    label: the gate starts closed to nothing (:data:`BLOCKING_START`) and is learnt.

    With ``binary_blocking`` too the gate is a switch: a move is open (no added cost) or blocked
    (:data:`BLOCKED_COST` added) as its gate logit is at most or above 0, so a blocked move stays blocked on a map
    of any size however short the training mazes' detours were. A switch has no gradient; the backward pass
    uses a surrogate's (:class:`BlockingSwitch`, a straight-through estimator), at the agent's cell only (see
    :meth:`forward`). Why: a
    continuous gate (the sigmoid above) is still a cost, and the labels stop raising a cost as soon as it beats
    the training mazes' detours (two looks in ``results/planning_learner/selection/``); a switch pushed across 0
    is blocked for good. Every gate starts open (:data:`BINARY_BLOCKING_START`). A move once blocked gets no
    gradient from the value iteration's maximum (it routes round it) except at the agent's own cell, where the
    labels' cross-entropy reaches every move: so a labelled move wrongly blocked is reopened by its labels.

    With ``cell_blocking`` too the switch is one per cell, not one per move: a move is blocked when the switch of the
    cell it leads into is shut, and that switch is read from the cell's own view (the gate's convolutions, one
    output channel). What is fixed is the value iteration's transition form: a move's added cost is its destination
    cell's switch (as a grid world's transition depends on the cell moved into); what is learnt is which cells are
    shut, from their views, starting with every cell open. Why: a per-move gate sees a free move that no label made
    as it sees a wall (its view is the source cell's), and shut free moves; every labelled move leads into a free
    cell, so labels open the free cells' shared view and only the cells the labels avoid are pushed shut.

    Args:
        iterations: Rounds of value propagation (at least the longest path, in cells).
        channels: Hidden channels of the cost map's convolutions.
        block_walls: Rule out the moves the walls block (their cost is :data:`BLOCKED_COST`).
        learnt_blocking: Add the learnt blocking gate.
        binary_blocking: Make that gate a switch (open or blocked), learnt through a surrogate gradient.
        cell_blocking: One switch per cell, read for every move into it (needs ``binary_blocking``).

    Raises:
        ValueError: If ``iterations`` is below 1, both ``block_walls`` and ``learnt_blocking`` are set,
            ``binary_blocking`` is set without ``learnt_blocking``, or ``cell_blocking`` without ``binary_blocking``.
    """

    def __init__(
        self,
        iterations: int,
        channels: int = 16,
        *,
        block_walls: bool = False,
        learnt_blocking: bool = False,
        binary_blocking: bool = False,
        cell_blocking: bool = False,
    ) -> None:
        super().__init__()
        if iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {iterations}")
        if block_walls and learnt_blocking:
            raise ValueError("block_walls and learnt_blocking exclude each other: walls are either given or learnt")
        if binary_blocking and not learnt_blocking:
            raise ValueError("binary_blocking needs learnt_blocking: it makes the learnt gate a switch")
        if cell_blocking and not binary_blocking:
            raise ValueError("cell_blocking needs binary_blocking: it makes the switch one per cell")
        self.iterations = iterations
        self.block_walls = block_walls
        self.binary_blocking = binary_blocking
        self.cell_blocking = cell_blocking
        self.cost = nn.Sequential(
            nn.Conv2d(2, channels, 3, padding=1),
            nn.ReLU(),
            nn.Conv2d(channels, len(NEXT_CELL_MOVES), 3, padding=1),
            nn.Softplus(),
        )
        self.blocking: nn.Sequential | None = None
        if learnt_blocking:
            self.blocking = nn.Sequential(
                nn.Conv2d(2, channels, 3, padding=1),
                nn.ReLU(),
                nn.Conv2d(channels, 1 if cell_blocking else len(NEXT_CELL_MOVES), 3, padding=1),
                nn.Sigmoid(),
            )
            with th.no_grad():
                self.blocking[2].bias.fill_(BINARY_BLOCKING_START if binary_blocking else BLOCKING_START)

    def blocking_logits(self, grids: th.Tensor) -> th.Tensor:
        """``(B, 9, S, S)`` logits of the learnt blocking gate (its ``b_a(s)`` is their sigmoid).

        With ``cell_blocking``, ``(B, 1, S, S)``: one switch logit per cell.

        Raises:
            ValueError: If the planner has no learnt gate.
        """
        if self.blocking is None:
            raise ValueError("this planner has no learnt blocking gate (learnt_blocking=False)")
        return self.blocking[:-1](grids)  # all but the closing sigmoid

    def blocking_cost(self, grids: th.Tensor) -> th.Tensor:
        """``(B, 9, S, S)`` cost the learnt gate adds to each move: :data:`BLOCKED_COST` times its ``b_a(s)``.

        With ``binary_blocking``, ``b_a(s)`` is 1 where the gate's logit is above 0, else 0, and the gradient a
        surrogate's (:class:`BlockingSwitch`).

        Raises:
            ValueError: If the planner has no learnt gate.
        """
        logits = self.blocking_logits(grids)
        if not self.binary_blocking:
            return BLOCKED_COST * th.sigmoid(logits)  # the closing nn.Sigmoid's op: the same figures
        if self.cell_blocking:
            # Each move's cost is the switch of the cell it leads into; beyond the grid the value is UNREACHED anyway.
            return shifted(BlockingSwitch.apply(logits[:, 0]), grids.shape[-1], fill=0.0)
        return BlockingSwitch.apply(logits)

    def forward(self, grids: th.Tensor) -> th.Tensor:
        """``(B, 9)`` Q-values of the moves from the agent's cell."""
        if self.binary_blocking:
            q, centre_gate = self.q_and_centre_gate(grids)
            return q - centre_gate
        return self.q_and_blocking_logits(grids)[0]

    def q_and_blocking_logits(self, grids: th.Tensor) -> tuple[th.Tensor, th.Tensor | None]:
        """:meth:`forward`'s Q-values and the :meth:`blocking_logits` they were planned with.

        The gate logits are ``None`` without a learnt gate. One pass of the gate's convolutions gives both, so a
        loss on both (``blocking_pressure``) runs them once.

        Raises:
            ValueError: For a switch (``binary_blocking``): its Q is :meth:`q_and_centre_gate`'s.
        """
        if self.binary_blocking:
            raise ValueError("a switch planner's Q comes from q_and_centre_gate (binary_blocking)")
        cost = self.cost(grids)
        if self.block_walls:
            cost = cost + BLOCKED_COST * blocked_moves((grids[:, 0] > 0.5).to(grids.dtype))
        gate_logits = None
        if self.blocking is not None:
            gate_logits = self.blocking[:-1](grids)
            cost = cost + BLOCKED_COST * self.blocking[-1](gate_logits)  # the closing sigmoid, as self.blocking(grids)
        centre = grids.shape[-1] // 2
        return self._ahead(grids, cost) - cost[:, :, centre, centre], gate_logits

    def q_and_centre_gate(self, grids: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """A switch planner's Q before the switch's cost at the agent's cell, and that ``(B, 9)`` cost.

        Apart, so that a readout can scale the one and not the other (:class:`NextCellNetwork`).

        Raises:
            ValueError: Without ``binary_blocking``.
        """
        if not self.binary_blocking:
            raise ValueError("q_and_centre_gate needs a switch planner (binary_blocking)")
        cost = self.cost(grids)
        centre = grids.shape[-1] // 2
        centre_cost = cost[:, :, centre, centre]
        gate = self.blocking_cost(grids)
        # The switch learns at the agent's cell only (the same values either way): through the maximum every move of
        # every competing path is pushed up, and those paths are longer, a drift that blocked most free moves within
        # 250 steps on the ant's 4x4 labels.
        return self._ahead(grids, cost + gate.detach()) - centre_cost, gate[:, :, centre, centre]

    def _ahead(self, grids: th.Tensor, cost: th.Tensor) -> th.Tensor:
        """``(B, 9)``: the value one move away of each move from the agent's cell, planned with ``cost``."""
        not_goal = (grids[:, 1] <= 0.5).to(grids.dtype)
        value = UNREACHED * not_goal
        size = grids.shape[-1]
        for _ in range(self.iterations - 1):
            # Holding V = 0 on the goal by a product, and no clamp: the fewest ops (the loop is the step's cost).
            value = (shifted(value, size) - cost).amax(dim=1) * not_goal
        centre = size // 2
        # The last round only at the agent's cell: Q of each move is the value one move away less its cost.
        return th.stack([value[:, centre - dy, centre + dx] for dx, dy in NEXT_CELL_MOVES], dim=1)


def shifted(value: th.Tensor, size: int, fill: float = UNREACHED) -> th.Tensor:
    """``(B, 9, S, S)``: for each move of :data:`NEXT_CELL_MOVES`, the value of the cell one move away.

    Rows run top (+y) to bottom, so move ``(dx, dy)`` reads row ``-dy``, column ``+dx``; cells beyond the
    grid read ``fill``.
    """
    padded = nn.functional.pad(value, (1, 1, 1, 1), value=fill)
    return th.stack([padded[:, 1 - dy : 1 - dy + size, 1 + dx : 1 + dx + size] for dx, dy in NEXT_CELL_MOVES], dim=1)


class NextCellNetwork(nn.Module):
    """Logits over the 3x3 cells around the agent (:data:`NEXT_CELL_MOVES`): which one to walk to next.

    With ``planning_iterations > 0`` the logits are the Q-values of a :class:`CellValueIteration` at the
    agent's cell plus a small correction from the feature vector (in-cell offset, velocity) and those
    Q-values, which starts at zero; with 0, a CNN and an MLP over grid and vector give them.

    Args:
        grid_size: Side of the agent-centred grid.
        vector_dim: Length of the feature vector.
        channels: Convolution channels.
        hidden: Width of the fully connected layers.
        planning_iterations: Value-iteration rounds; 0: the CNN instead.
        block_walls: The planner rules out moves the walls block (:class:`CellValueIteration`).
        learnt_blocking: The planner learns which moves are never made (:class:`CellValueIteration`).
        binary_blocking: That learnt gate is a switch, open or blocked (:class:`CellValueIteration`).
        cell_blocking: That switch is one per cell, read for the moves into it (:class:`CellValueIteration`).
        any_map: The planning learner whose weights act on any map: the logits are the planner's Q alone,
            times a learnt trust that starts at 0 (so the untrained learner has no preference among moves),
            with no correction from the feature vector (whose goal offset grows with the map beyond anything
            trained on: with it, zero-shot grid-level success on ``large`` was 56% against 91%, medians of 3
            seeds in ``results/planning_learner/``; a correction from local inputs only did worse on the screen too).

    Raises:
        ValueError: If ``any_map`` or ``learnt_blocking`` is given without planning, ``binary_blocking``
            without ``learnt_blocking``, or ``cell_blocking`` without ``binary_blocking``.
    """

    def __init__(
        self,
        grid_size: int,
        vector_dim: int,
        channels: int = 16,
        hidden: int = 128,
        planning_iterations: int = 0,
        *,
        block_walls: bool = False,
        any_map: bool = False,
        learnt_blocking: bool = False,
        binary_blocking: bool = False,
        cell_blocking: bool = False,
    ) -> None:
        super().__init__()
        moves = len(NEXT_CELL_MOVES)
        if any_map and planning_iterations < 1:
            raise ValueError("any_map needs planning_iterations > 0")
        if learnt_blocking and planning_iterations < 1:
            raise ValueError("learnt_blocking needs planning_iterations > 0")
        self.trust: nn.Parameter | None = None
        self.head: nn.Module | None = None
        if planning_iterations > 0:
            self.planner: CellValueIteration | None = CellValueIteration(
                planning_iterations,
                channels,
                block_walls=block_walls,
                learnt_blocking=learnt_blocking,
                binary_blocking=binary_blocking,
                cell_blocking=cell_blocking,
            )
            if any_map:
                # How far the logits follow the planner, learnt from 0: untrained, every move is as likely (the
                # planner's goal-seeking prior alone solved a third of the ant's mazes before any label).
                self.trust = nn.Parameter(th.zeros(()))
            else:
                self.head = nn.Sequential(nn.Linear(moves + vector_dim, hidden), nn.ReLU(), nn.Linear(hidden, moves))
                with th.no_grad():  # start as the planner's own readout
                    self.head[-1].weight.zero_()
                    self.head[-1].bias.zero_()
        else:
            self.planner = None
            self.head = SubgoalNetwork(grid_size, vector_dim, moves, channels, hidden)

    def switch_readout(self, grids: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """The two parts of an ``any_map`` switch learner's logits: ``trust * relative - switch`` (:meth:`forward`).

        ``relative``: the planner's Q less its best move's (the same softmax), floored at :data:`LOGIT_FLOOR` below
        it, so the trust sees no cut-off cell's ``UNREACHED``; ``switch``: the switch's ``(B, 9)`` cost at the
        agent's cell, not scaled by the trust, so a blocked move is out whatever the trust (it starts at 0) and
        the switch learns at the labels' pace.

        Raises:
            ValueError: If this is not an ``any_map`` planner with ``binary_blocking``.
        """
        if self.trust is None or self.planner is None or not self.planner.binary_blocking:
            raise ValueError("switch_readout needs an any_map planner with binary_blocking")
        q, centre_gate = self.planner.q_and_centre_gate(grids)
        assert centre_gate is not None
        relative = q - q.max(dim=1, keepdim=True).values.detach()
        return relative.clamp(min=-LOGIT_FLOOR), centre_gate

    def forward(self, grids: th.Tensor, vectors: th.Tensor) -> th.Tensor:
        """Logits ``(B, 9)`` over the next cell."""
        return self.logits_and_blocking_logits(grids, vectors)[0]

    def logits_and_blocking_logits(self, grids: th.Tensor, vectors: th.Tensor) -> tuple[th.Tensor, th.Tensor | None]:
        """:meth:`forward`'s logits and the planner's learnt gate logits ``(B, 9, S, S)`` they were computed with.

        From one pass (:meth:`CellValueIteration.q_and_blocking_logits`); the gate logits are ``None`` without a
        learnt gate.
        """
        if self.planner is None:
            assert self.head is not None
            return self.head(grids, vectors)[0], None
        if self.trust is not None and self.planner.binary_blocking:
            relative, centre_gate = self.switch_readout(grids)
            return self.trust * relative - centre_gate, None
        q, gate_logits = self.planner.q_and_blocking_logits(grids)
        if self.trust is not None:
            return self.trust * q, gate_logits
        assert self.head is not None
        # The correction sees Q relative to its best move: the scale of Q grows with the iterations.
        relative = q - q.max(dim=1, keepdim=True).values.detach()
        return q + self.head(th.cat([relative, vectors], dim=1)), gate_logits
