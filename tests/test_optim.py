"""ZeroSafeAdam: torch's foreach Adam, the same weights and moments bit for bit, only faster on exact zeros."""

import copy

import numpy as np
import pytest
import torch as th
from torch import nn

from antmaze_hirl.dagger.network import SubgoalNetwork
from antmaze_hirl.dagger.optim import ZeroSafeAdam, zero_root_is_absorbed


def train(optimizer_class, steps, **options):
    """The learner's CNN (the ant's grid and vector sizes) trained on sparse 0/1 grids, as the learner's are."""
    th.manual_seed(0)
    network = SubgoalNetwork(11, 31, n_directions=9)
    optimizer = optimizer_class(network.parameters(), lr=1e-3, foreach=True, **options)
    rng = np.random.default_rng(0)
    for _ in range(steps):
        grids = (rng.random((64, 2, 11, 11)) < 0.1).astype(np.float32)
        grids[:, :, :3] = 0.0  # rows no sample ever fills: weights whose gradient stays exactly zero
        vectors = rng.normal(size=(64, 31)).astype(np.float32)
        logits, _ = network(th.from_numpy(grids), th.from_numpy(vectors))
        loss = nn.functional.cross_entropy(logits, th.from_numpy(rng.integers(9, size=64)))
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    return network, optimizer


STEPS = 60
"""Training steps of each run compared (any step whose rounding differs breaks the bits from there on)."""


def same_bits(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and bool((a.view(th.int32) == b.view(th.int32)).all())


@pytest.mark.parametrize("options", [{}, {"weight_decay": 0.01}])
def test_the_weights_and_moments_are_torchs_bit_for_bit(options):
    # Weight decay is not reproduced: that case must run torch's own step, and so agree as well.
    lean_steps = []
    original = ZeroSafeAdam._lean_step

    def counted(*args, **kwargs):
        lean_steps.append(1)
        return original(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ZeroSafeAdam, "_lean_step", staticmethod(counted))
        mine, my_optimizer = train(ZeroSafeAdam, STEPS, **options)
    # Without weight decay the lean step must have run (else the test would only compare torch with torch);
    # with it, torch's own step runs every time.
    assert (len(lean_steps) > STEPS * 2 // 3) if not options else not lean_steps, len(lean_steps)
    theirs, their_optimizer = train(th.optim.Adam, STEPS, **options)
    for (name, a), b in zip(mine.named_parameters(), theirs.parameters(), strict=True):
        assert same_bits(a.detach(), b.detach()), name
        if b in their_optimizer.state:
            for key in ("exp_avg", "exp_avg_sq", "step"):
                assert same_bits(my_optimizer.state[a][key], their_optimizer.state[b][key]), (name, key)
    if not options:  # the case the clamp is for did occur (weight decay leaves no gradient at zero)
        assert (their_optimizer.state[theirs.body[0].weight]["exp_avg_sq"] == 0).float().mean() > 0.1


def test_the_state_dict_moves_between_the_two():
    network, optimizer = train(ZeroSafeAdam, 5)
    copied = copy.deepcopy(network)
    torchs = th.optim.Adam(copied.parameters(), lr=1e-3, foreach=True)
    torchs.load_state_dict(optimizer.state_dict())
    assert torchs.state_dict()["state"].keys() == optimizer.state_dict()["state"].keys()


def test_the_zero_root_bound():
    assert zero_root_is_absorbed(1e-8, 0.999)
    # An eps so small that sqrt(tiny) / sqrt(1 - beta2) shows in the sum: the clamp would change the result.
    assert not zero_root_is_absorbed(1e-20, 0.999)
    assert not zero_root_is_absorbed(1e-8, 1.0)
