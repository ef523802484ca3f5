"""The benchmark suites' fixed facts: names, registered ids, bodies, sizes and checksums (plain data, no MuJoCo).

A suite is a fixed, versioned list of evaluation tasks (walls, start cell, goal cell, low-level step limit)
stored in ``antmaze_hirl/envs/benchmark_suites.json`` and played by
:class:`~antmaze_hirl.envs.suites.SuiteMazeEnv`. This module holds only what registration and the CLI need
without reading that file or importing the simulator; :mod:`antmaze_hirl.envs.suites` checks the file
against :attr:`SuiteSpec.checksum`, so an edited or damaged task list is refused, not scored.
"""

from __future__ import annotations

from dataclasses import dataclass

from antmaze_hirl.envs.bodies import Body

SUITE_VERSION = 0
"""The ``-v0`` of every suite id. A changed task list is a new version (new id, new checksum), never an edit."""

LOW_LEVEL_STEPS_PER_SUBGOAL = 5
"""The spec's ``max_episode_steps`` (subgoals) is a task's largest low-level step limit over this: a subgoal
closer than the env's ``min_subgoal_distance_m`` is pushed out, so no subgoal takes fewer low-level steps in
practice, and the low-level limit stays the binding one (the oracle uses 4-21 subgoals per episode)."""


@dataclass(frozen=True)
class SuiteSpec:
    """One suite's fixed facts.

    Attributes:
        name: The suite's short name (``antmaze-hirl benchmark NAME``).
        env_id: Its registered Gymnasium id.
        body: ``"point"`` or ``"ant"``.
        source: ``"random"`` (a random family's maze size) or a fixed map's name.
        maze_size: Free cells per side of the random family; ``None`` for a fixed map.
        n_tasks: Tasks in the list.
        max_low_level_steps: The largest per-task low-level step limit.
        checksum: SHA-256 of the task list (:func:`antmaze_hirl.envs.suites.tasks_checksum`).
        episodes_per_task: The protocol's episodes per task, K: 1 on a random family (100 mazes), 20 on a
            fixed map (100 episodes over 5 tasks; OGBench plays 50 per task), each with its own start and goal
            noise.
    """

    name: str
    env_id: str
    body: Body
    source: str
    maze_size: int | None
    n_tasks: int
    max_low_level_steps: int
    checksum: str
    episodes_per_task: int = 1

    @property
    def max_episode_steps(self) -> int:
        """The spec's high-level step limit, in subgoals (see :data:`LOW_LEVEL_STEPS_PER_SUBGOAL`)."""
        return -(-self.max_low_level_steps // LOW_LEVEL_STEPS_PER_SUBGOAL)


SUITE_SPECS: dict[str, SuiteSpec] = {
    spec.name: spec
    for spec in (
        SuiteSpec(
            "point5",
            "antmaze_hirl/PointMaze-5x5-v0",
            "point",
            "random",
            5,
            100,
            500,
            "63de7a54329766843be615c6cae1ea1e72cc8ed13911c0c6d3fe5c82c7197fc1",
        ),
        SuiteSpec(
            "ant4",
            "antmaze_hirl/AntMaze-4x4-v0",
            "ant",
            "random",
            4,
            100,
            500,
            "100530cd4d47ddf9e98402683dba85adf964cc56eb9d3224188fe9553f7b463b",
        ),
        SuiteSpec(
            "u",
            "antmaze_hirl/AntMaze-u-v0",
            "ant",
            "u",
            None,
            5,
            960,
            "1e3a297858444af78ceaacad7613c898399ce9d5bdd7a1524824ca1677b821e0",
            20,
        ),
        SuiteSpec(
            "medium",
            "antmaze_hirl/AntMaze-medium-v0",
            "ant",
            "medium",
            None,
            5,
            1600,
            "dd00145768a21ebf331971b89310741654197a2587e047b5b6241fc0a3bed770",
            20,
        ),
        SuiteSpec(
            "large",
            "antmaze_hirl/AntMaze-large-v0",
            "ant",
            "large",
            None,
            5,
            3040,
            "0a2b43afd252ef12ccabd52a8fa08a0a9eebcdf61aefed594e7ec7144c04496b",
            20,
        ),
        SuiteSpec(
            "giant",
            "antmaze_hirl/AntMaze-giant-v0",
            "ant",
            "giant",
            None,
            5,
            4800,
            "4df9aa760368eaff67cf1eacaa310ec710d44730d909dc69eca8833e32166395",
            20,
        ),
    )
}
"""Every suite, by name. Checksums and step limits are those of ``benchmark_suites.json``
(``scripts/make_suites.py`` regenerates it byte for byte)."""

SUITE_ENTRY_POINT = "antmaze_hirl.sb3_ext.suite_envs:make_suite_env"
"""Entry point of every suite id: the suite env with the body's shipped low level unless one is given."""


def check_suite_name(name: str) -> SuiteSpec:
    """The spec of suite ``name``.

    Raises:
        ValueError: Naming the value and the suites, if ``name`` is no suite.
    """
    if name not in SUITE_SPECS:
        raise ValueError(f"unknown benchmark suite {name!r}; choose one of {list(SUITE_SPECS)}")
    return SUITE_SPECS[name]
