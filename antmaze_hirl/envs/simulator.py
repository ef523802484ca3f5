"""One gymnasium-robotics maze simulation (Ant or point mass) that places the body at exact xy."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from gymnasium_robotics.envs.maze.ant_maze_v5 import AntMazeEnv
from gymnasium_robotics.envs.maze.maze_v4 import MazeEnv
from gymnasium_robotics.envs.maze.point_maze import PointMazeEnv

from antmaze_hirl.envs.bodies import BODY_SPECS, Body, BodySpec, body_spec, uprightness
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import walls_to_maze_map

__all__ = ["BODY_SPECS", "Body", "BodySpec", "MazeSimulator", "body_spec", "uprightness"]

TARGET_MARKER_RADIUS_CELLS = 0.06
"""Radius of the red subgoal marker in the MuJoCo view, in cells (gymnasium-robotics draws 0.2)."""
TARGET_MARKER_ALPHA = 0.5
"""Its opacity (gymnasium-robotics: 0.7), so that the body shows through where they overlap."""


class MazeSimulator:
    """Owns the gymnasium-robotics ``AntMazeEnv``/``PointMazeEnv`` for one wall layout.

    The maze env builds the MuJoCo model (walls added to the stock Ant/point XML); this class only
    drives its body directly, skipping the maze env's own goal bookkeeping, which our envs replace.
    Observations exclude the body's xy (returned separately), so policies are translation invariant.

    Args:
        body: ``"ant"`` or ``"point"``.
        walls: Boolean wall grid of the layout.
        include_contact_forces: Ant only: keep the 78 contact-force entries in the observation.

    """

    def __init__(self, body: Body, walls: np.ndarray, *, include_contact_forces: bool = False) -> None:
        self.body = body
        self.include_contact_forces = bool(include_contact_forces)
        self.spec = body_spec(body)
        self.walls = np.array(walls, dtype=bool)
        self.geometry = MazeGeometry(self.walls.shape[0], self.walls.shape[1], self.spec.scale)
        maze_map = walls_to_maze_map(self.walls)
        self._maze_env: MazeEnv
        if body == "ant":
            self._maze_env = AntMazeEnv(maze_map=maze_map, include_cfrc_ext_in_observation=include_contact_forces)
            self._mujoco_env = self._maze_env.ant_env
        else:
            self._maze_env = PointMazeEnv(maze_map=maze_map)
            self._mujoco_env = self._maze_env.point_env
        # The model is compiled; the XML gymnasium-robotics wrote to the temp dir is no longer needed.
        os.remove(self._maze_env.tmp_xml_file_path)
        self._shrink_target_marker()
        self.action_space = self._mujoco_env.action_space
        self.observation_dim = int(self._mujoco_env.observation_space.shape[0]) - 2

    def reset(self, xy: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Puts the body at rest at ``xy`` and returns ``(observation, xy)``."""
        self._mujoco_env.init_qpos[:2] = xy
        raw_obs, _ = self._mujoco_env.reset(seed=seed)
        return self._split(raw_obs)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advances one env step (``spec.dt`` seconds) and returns ``(observation, xy)``."""
        if self.body == "ant":
            # Ant-v5's step() is this simulation and this observation, plus its locomotion reward, health check
            # and info dict, which nothing here reads: about a fifth of an ant step's CPU time. The observations
            # are bit for bit the same (tests/test_simulator.py). Its render is for render_mode="human", never set.
            if not self.include_contact_forces:
                return self._step_ant_without_forces(action)
            self._mujoco_env.do_simulation(action, self._mujoco_env.frame_skip)
            return self._split(self._mujoco_env._get_obs())
        raw_obs = self._mujoco_env.step(action)[0]
        return self._split(raw_obs)

    def _shrink_target_marker(self) -> None:
        # gymnasium-robotics' red target sphere has a radius of 0.2 cell (0.8 m on the ant, three times the
        # torso's) at 70% opacity, so in the MuJoCo view it hid the ant walking to it. A site is visual only:
        # a smaller, fainter one changes no dynamics.
        import mujoco

        model = self._mujoco_env.model
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "target")
        if site >= 0:
            model.site_size[site, 0] = TARGET_MARKER_RADIUS_CELLS * self.spec.scale
            model.site_rgba[site, 3] = TARGET_MARKER_ALPHA

    def show_target(self, xy: np.ndarray) -> None:
        """Moves the red target marker of the MuJoCo scene (visual only)."""
        self._maze_env.goal = np.asarray(xy, dtype=np.float64)
        self._maze_env.update_target_site_pos()

    @property
    def data(self) -> Any:
        """The live ``mujoco.MjData`` (positions, velocities, applied controls, contacts).

        Its force outputs (``cacc``, ``cfrc_int``, ``cfrc_ext``) are up to date after an ant step only with
        ``include_contact_forces``, the one observation that reads them.
        """
        return self._mujoco_env.data

    @property
    def torso_height(self) -> float:
        """Height of the body's root above the floor, metres."""
        return float(self._mujoco_env.data.qpos[2]) if self.body == "ant" else 0.0

    @property
    def uprightness(self) -> float:
        """World z component of the torso's up axis: 1 upright, 0 on its side, -1 on its back (point: 1).

        For the torso quaternion ``(qw, qx, qy, qz)`` it is ``1 - 2 (qx^2 + qy^2)``.
        """
        return uprightness(self._mujoco_env.data.qpos[3:7]) if self.body == "ant" else 1.0

    @property
    def is_flipped(self) -> bool:
        """Ant only: whether the torso faces down or lies on the floor.

        An ant on its back rests at about 0.27 m, above any sensible height threshold, so the torso's
        up axis (:attr:`uprightness`) is checked too.
        """
        return self.posture()[0]

    def posture(self) -> tuple[bool, float]:
        """``(is_flipped, uprightness)`` (:attr:`is_flipped`, :attr:`uprightness`), the quaternion read once."""
        upright = self.uprightness  # the point body's 1.0 comes from here too
        return self.body == "ant" and bool(upright < 0 or self.torso_height < 0.2), upright

    def close(self) -> None:
        """Frees the MuJoCo renderer, if one was opened."""
        self._mujoco_env.close()

    def _step_ant_without_forces(self, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # Gymnasium's do_simulation without its closing mj_rnePostConstraint, and Ant-v5's observation read
        # straight from qpos and qvel. That call only fills MjData's force outputs (cacc, cfrc_int, cfrc_ext) for
        # the contact-force observation; mj_step never reads them, so the trajectory is the same bit for bit
        # (tests/test_simulator.py), a few percent of an ant step's CPU time cheaper. ``data`` then holds
        # no up-to-date cfrc_ext: only include_contact_forces (the other branch) reads it.
        import mujoco

        env = self._mujoco_env
        action = np.asarray(action)
        if action.shape != (env.model.nu,):  # do_simulation's check
            raise ValueError(f"Action dimension mismatch. Expected {(env.model.nu,)}, found {action.shape}")
        data = env.data
        data.ctrl[:] = action
        mujoco.mj_step(env.model, data, nstep=env.frame_skip)
        qpos = data.qpos
        return np.concatenate((qpos[2:], data.qvel)), qpos[:2].copy()

    def _split(self, raw_obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return raw_obs[2:].copy(), raw_obs[:2].copy()
