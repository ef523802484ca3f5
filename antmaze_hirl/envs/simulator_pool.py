"""Idle MuJoCo maze simulators kept by wall grid, so that an env coming back to a maze skips its compile.

Building a :class:`~antmaze_hirl.envs.simulator.MazeSimulator` compiles the maze's MuJoCo model from XML,
the slow part of building an env, and an env builds one for every new layout. A protocol-2
trial plays the same 100 evaluation mazes 11 times, so without a pool it compiles about 1,100 models for
100 distinct grids. An env hands the simulator of the layout it leaves back to the pool and takes one
for the layout it enters; a simulator is held by one env at a time.

A reused simulator plays exactly as a fresh one: every episode starts with ``MazeSimulator.reset``, which
resets the whole ``MjData`` (``mj_resetData``) and reseeds the body's noise, and the model itself is never
changed except for the goal marker's site, which is visual only (``tests/test_simulator_pool.py``).
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from antmaze_hirl.envs.simulator import Body, MazeSimulator

__all__ = ["DEFAULT_CAPACITY", "SimulatorPool", "acquire_simulator", "release_simulator", "shared_pool"]

DEFAULT_CAPACITY = 120
"""Idle simulators the process keeps. Between two protocol-2 evaluations the pool must hold the evaluation
mazes the lockstep copies are not holding (75 of 100 with 25 copies) while the training mazes of 10
episodes pass through; the least recently released go first, so those are the ones dropped. Memory: a
point-mass simulator holds about 12 MiB (gymnasium-robotics' 800x4800 skybox texture is 11 MiB of its
model), an ant one about 1 MiB, so a full pool of point simulators holds about 1.4 GiB per process; lower
it with ``shared_pool().capacity = n``."""

_Key = tuple[str, bool, tuple[int, ...], bytes]


class SimulatorPool:
    """Idle simulators keyed by body, contact-force setting and wall grid, least recently released dropped first.

    Args:
        capacity: Idle simulators kept; releasing one more closes the least recently released. 0 keeps none.

    Raises:
        ValueError: If ``capacity`` is negative.
    """

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 0:
            raise ValueError(f"capacity must be >= 0, got {capacity}")
        self.capacity = capacity
        self._idle: OrderedDict[tuple[_Key, int], MazeSimulator] = OrderedDict()
        self._lock = threading.Lock()
        self._released = 0  # a unique suffix per idle entry, so that one grid may have several idle simulators
        self.hits = 0
        self.misses = 0

    def __len__(self) -> int:
        return len(self._idle)

    @staticmethod
    def key(body: str, walls: np.ndarray, include_contact_forces: bool) -> _Key:
        """The pool's key of a simulator for ``walls``."""
        grid = np.asarray(walls, dtype=bool)
        return body, bool(include_contact_forces), grid.shape, np.packbits(grid).tobytes()

    def acquire(self, body: Body, walls: np.ndarray, *, include_contact_forces: bool = False) -> MazeSimulator:
        """An idle simulator of this maze if the pool has one (it leaves the pool), else a new one."""
        wanted = self.key(body, walls, include_contact_forces)
        with self._lock:  # the study server steps participants' sessions on several threads
            for entry in reversed(self._idle):  # the most recently released first
                if entry[0] == wanted:
                    self.hits += 1
                    return self._idle.pop(entry)
            self.misses += 1
        return MazeSimulator(body, walls, include_contact_forces=include_contact_forces)

    def release(self, simulator: MazeSimulator) -> None:
        """Takes back a simulator its env no longer uses; the caller must not touch it afterwards."""
        key = self.key(simulator.body, simulator.walls, simulator.include_contact_forces)
        dropped = []
        with self._lock:
            self._released += 1
            self._idle[(key, self._released)] = simulator
            while len(self._idle) > self.capacity:
                dropped.append(self._idle.popitem(last=False)[1])
        for old in dropped:
            old.close()

    def clear(self) -> None:
        """Closes and drops every idle simulator."""
        with self._lock:
            dropped = list(self._idle.values())
            self._idle.clear()
        for old in dropped:
            old.close()


_POOL = SimulatorPool()


def shared_pool() -> SimulatorPool:
    """The process's pool, which every :class:`~antmaze_hirl.envs.reach.ReachEnv` uses."""
    return _POOL


def acquire_simulator(body: Body, walls: np.ndarray, *, include_contact_forces: bool = False) -> MazeSimulator:
    """:meth:`SimulatorPool.acquire` on the process's pool."""
    return _POOL.acquire(body, walls, include_contact_forces=include_contact_forces)


def release_simulator(simulator: MazeSimulator) -> None:
    """:meth:`SimulatorPool.release` on the process's pool."""
    _POOL.release(simulator)
