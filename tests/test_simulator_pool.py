"""The simulator pool: an env coming back to a maze reuses its simulator, and plays exactly as a fresh one."""

import numpy as np
import pytest

from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.envs.simulator_pool import SimulatorPool, shared_pool

OPEN = [[1, 1, 1, 1, 1], [1, 0, 0, 0, 1], [1, 0, 0, 0, 1], [1, 0, 0, 0, 1], [1, 1, 1, 1, 1]]
WALLED = [[1, 1, 1, 1, 1], [1, 0, 0, 0, 1], [1, 0, 1, 0, 1], [1, 0, 0, 0, 1], [1, 1, 1, 1, 1]]


def rollout(env, seed, steps=30):
    """Observations of ``steps`` steps of a fixed action sequence after ``reset(seed=seed)``."""
    obs, _ = env.reset(seed=seed)
    trace = [obs["observation"].copy(), obs["achieved_goal"].copy()]
    actions = np.random.default_rng(seed).uniform(-1, 1, size=(steps, *env.action_space.shape))
    for action in actions:
        obs, *_ = env.step(action)
        trace += [obs["observation"].copy(), obs["achieved_goal"].copy()]
    return np.concatenate(trace)


def test_an_env_back_on_a_maze_reuses_its_simulator_and_plays_as_a_fresh_env():
    env = ReachEnv("point", OPEN)
    first = env.sim
    rollout(env, seed=4)  # the pooled simulator has played an episode before it is reused
    env.set_walls(np.asarray(WALLED, dtype=bool))
    assert env.sim is not first
    hits = shared_pool().hits
    env.set_walls(np.asarray(OPEN, dtype=bool))
    assert env.sim is first and shared_pool().hits == hits + 1
    reused = rollout(env, seed=11)
    fresh_env = ReachEnv("point", OPEN)
    assert fresh_env.sim is not first
    np.testing.assert_array_equal(reused, rollout(fresh_env, seed=11))
    env.close()
    fresh_env.close()


def test_two_envs_on_one_maze_never_share_a_simulator():
    first, second = ReachEnv("point", WALLED), ReachEnv("point", WALLED)
    assert first.sim is not second.sim
    first.close()
    second.close()


def test_the_pool_keys_by_walls_and_contact_forces_and_drops_the_least_recently_released():
    pool = SimulatorPool(capacity=2)
    open_walls, walled = np.asarray(OPEN, dtype=bool), np.asarray(WALLED, dtype=bool)
    a, b, c = (pool.acquire("point", walls) for walls in (open_walls, walled, open_walls))
    assert pool.misses == 3 and len(pool) == 0
    for simulator in (a, b, c):
        pool.release(simulator)
    assert len(pool) == 2  # a, the least recently released, was closed and dropped
    assert pool.acquire("point", open_walls) is c
    assert pool.acquire("point", walled) is b
    assert pool.acquire("point", walled) is not b  # none idle left: a new one
    assert pool.key("point", open_walls, False) != pool.key("point", open_walls, True)
    assert pool.key("point", open_walls, False) != pool.key("point", walled, False)


def test_a_pool_of_capacity_zero_keeps_nothing_and_a_negative_one_is_refused():
    pool = SimulatorPool(capacity=0)
    simulator = pool.acquire("point", np.asarray(OPEN, dtype=bool))
    pool.release(simulator)
    assert len(pool) == 0 and pool.acquire("point", np.asarray(OPEN, dtype=bool)) is not simulator
    with pytest.raises(ValueError, match="capacity must be >= 0, got -1"):
        SimulatorPool(capacity=-1)


def test_threads_acquiring_and_releasing_at_once_never_get_one_simulator_twice():
    # The study server steps participants' sessions on several threads; each may move to a new maze.
    import threading

    pool = SimulatorPool(capacity=4)
    walls = np.asarray(OPEN, dtype=bool)
    pool.release(pool.acquire("point", walls))
    held, errors = [], []

    def work() -> None:
        try:
            for _ in range(5):
                simulator = pool.acquire("point", walls)
                held.append(id(simulator))
                pool.release(simulator)
        except Exception as error:  # any error in a thread fails the test below
            errors.append(error)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert pool.hits + pool.misses == 21 and len(pool) <= 4
    pool.clear()
    assert len(pool) == 0
