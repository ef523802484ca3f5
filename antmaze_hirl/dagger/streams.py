"""Independent random streams: one trial seed, one numpy Generator per consumer.

A DAgger trial has four consumers of randomness: the tasks (maze, goal and the env's reset seed), the
learner (initialisation, minibatches, augmentations), the query strategy (noise, ensembles, pruning) and
the trainer's own mixing (``"switch"``). Drawing them all from one Generator makes each consumer's
numbers depend on how many the others drew: a strategy that draws one extra number shifts every later
maze and every later minibatch, so two methods on the same seed no longer see the same tasks. Spawning
a child stream per consumer (``SeedSequence.spawn``) makes them independent by construction.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["TrainerStreams", "TrialStreams", "spawn_generators", "trainer_streams", "trial_streams"]


def spawn_generators(rng: np.random.Generator, count: int) -> list[np.random.Generator]:
    """``count`` child Generators of ``rng``, independent of each other and of ``rng``'s own draws.

    ``Generator.spawn`` derives them from ``rng``'s seed sequence without drawing from ``rng``: what
    ``rng`` itself has drawn, or will draw, changes none of them. A Generator built without a seed
    sequence (from a bare bit generator state) cannot spawn; its children are then seeded by one draw
    from it.

    Raises:
        ValueError: If ``count`` is below 1.
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    try:
        return list(rng.spawn(count))
    except TypeError:  # numpy: "SeedSequence expected", a bit generator without one
        children = np.random.SeedSequence(int(rng.integers(2**63))).spawn(count)
        return [np.random.default_rng(child) for child in children]


class TrainerStreams(NamedTuple):
    """The :class:`~antmaze_hirl.dagger.DAggerTrainer`'s streams, spawned from its ``rng``.

    Attributes:
        tasks: Each episode's maze and goal (``sample_task``) and the env's reset seed; the same for every
            method, since no method's choices draw from it.
        strategy: What the query strategy draws: noise, ensemble members, bootstrap samples, pruning.
        mixing: The trainer's ``"switch"`` mixing draws.
    """

    tasks: np.random.Generator
    strategy: np.random.Generator
    mixing: np.random.Generator


def trainer_streams(rng: np.random.Generator) -> TrainerStreams:
    """The trainer's three streams, spawned from ``rng`` (:func:`spawn_generators`)."""
    return TrainerStreams(*spawn_generators(rng, 3))


class TrialStreams(NamedTuple):
    """One trial's two top-level streams, spawned from its seed.

    Attributes:
        learner: The learner's ``rng``: its initialisation, then its minibatches and augmentations.
        trainer: The trainer's ``rng``, which spawns :class:`TrainerStreams` (tasks, strategy, mixing).
    """

    learner: np.random.Generator
    trainer: np.random.Generator


def trial_streams(seed: int) -> TrialStreams:
    """The streams of the trial seeded ``seed``: ``SeedSequence(seed).spawn(2)``, one Generator each."""
    learner, trainer = np.random.SeedSequence(seed).spawn(2)
    return TrialStreams(np.random.default_rng(learner), np.random.default_rng(trainer))
