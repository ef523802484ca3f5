"""MazeSimulator: its ant step plays exactly as Ant-v5's own step()."""

import mujoco
import numpy as np
import pytest

from antmaze_hirl.envs.simulator import MazeSimulator

WALLS = np.pad(np.zeros((4, 4), dtype=bool), 1, constant_values=True)
WALLS[2, 2] = True  # one inner wall, centred at (-2, 2) m; the start below it lets the legs touch it


@pytest.mark.parametrize("contact_forces", [False, True])
def test_the_ant_step_is_ant_v5s_step_bit_for_bit(contact_forces):
    fast, reference = (MazeSimulator("ant", WALLS, include_contact_forces=contact_forces) for _ in range(2))
    start = np.array([-2.0, -1.2])  # 1.2 m below the inner wall's face (y = 0)
    assert all(np.array_equal(a, b) for a, b in zip(fast.reset(start, 3), reference.reset(start, 3), strict=True))
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (300, 8))
    model = fast._mujoco_env.model
    walls = {
        g
        for g in range(model.ngeom)
        if (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "").startswith("block_")
    }
    steps_touching_a_wall = 0
    for action in actions:
        mine = fast.step(action)
        theirs = reference._split(reference._mujoco_env.step(action)[0])  # what step() returned before
        assert np.array_equal(mine[0], theirs[0]) and np.array_equal(mine[1], theirs[1])
        contacts = fast.data.contact[: fast.data.ncon]
        steps_touching_a_wall += any(c.geom1 in walls or c.geom2 in walls for c in contacts)
    assert steps_touching_a_wall > 0  # the equality was tested through wall contacts, not only floor ones
    assert np.array_equal(fast.data.qpos, reference.data.qpos) and np.array_equal(fast.data.qvel, reference.data.qvel)
    assert not np.allclose(fast.data.qpos[:2], start)  # it moved


def test_an_action_of_the_wrong_size_is_still_refused():
    with pytest.raises(ValueError, match="Action dimension mismatch"):
        MazeSimulator("ant", WALLS).step(np.zeros(3))


def test_posture_is_is_flipped_and_uprightness_read_together():
    simulator = MazeSimulator("ant", WALLS)
    simulator.reset(np.array([-4.0, -4.0]), 0)
    for action in np.random.default_rng(1).uniform(-1.0, 1.0, (50, 8)):
        simulator.step(action)
        assert simulator.posture() == (simulator.is_flipped, simulator.uprightness)
    assert MazeSimulator("point", WALLS).posture() == (False, 1.0)
