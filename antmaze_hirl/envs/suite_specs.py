"""The benchmark suites' fixed facts: names, registered ids, bodies, sizes and checksums (plain data, no MuJoCo).

A suite is a fixed, versioned list of evaluation tasks (walls, start cell, goal cell, low-level step limit)
stored in ``antmaze_hirl/envs/benchmark_suites.json`` and played by
:class:`~antmaze_hirl.envs.suites.SuiteMazeEnv`. This module holds only what registration and the CLI need
without reading that file or importing the simulator; :mod:`antmaze_hirl.envs.suites` checks the file
against :attr:`SuiteSpec.checksum`, so an edited or damaged task list is refused, not scored. A suite's body,
maze, id and step limit come from its family in :mod:`antmaze_hirl.envs.profiles`; only the task list's own
facts (its size, checksum and longest path) are stated here.
"""

from __future__ import annotations

from dataclasses import dataclass

from antmaze_hirl.envs.profiles import SUITE_FAMILIES, Body, body_spec, maze_env_id, path_scaled_step_limit

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
        episodes_per_task: The suite's episodes per task, K: 1 on a random family (100 mazes), 20 on a
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


def _suite_spec(
    name: str, n_tasks: int, checksum: str, *, longest_path_cells: int | None = None, episodes_per_task: int = 1
) -> SuiteSpec:
    """Suite ``name``'s spec, its body, maze, id and step limit read from its family.

    The family is ``name``'s entry in :data:`~antmaze_hirl.envs.profiles.SUITE_FAMILIES`.

    Args:
        name: A key of :data:`~antmaze_hirl.envs.profiles.SUITE_FAMILIES`.
        n_tasks: Tasks in the list.
        checksum: SHA-256 of the task list.
        longest_path_cells: For a path-scaled family, the grid steps of the longest task's shortest cell path,
            which sets :attr:`SuiteSpec.max_low_level_steps`.
        episodes_per_task: As :attr:`SuiteSpec.episodes_per_task`.

    Raises:
        ValueError: If a path-scaled family's ``longest_path_cells`` is missing, or a fixed limit's is given.
    """
    family = SUITE_FAMILIES[name]
    if (family.step_limit is None) != (longest_path_cells is not None):
        raise ValueError(
            f"suite {name!r}: longest_path_cells={longest_path_cells!r}; give it exactly for a path-scaled family"
        )
    if family.step_limit is None:
        max_steps = path_scaled_step_limit(longest_path_cells * body_spec(family.body).scale)
    else:
        max_steps = family.step_limit
    variant = family.source if family.maze_size is None else f"{family.maze_size}x{family.maze_size}"
    env_id = maze_env_id(family.body, variant, version=SUITE_VERSION)
    return SuiteSpec(
        name, env_id, family.body, family.source, family.maze_size, n_tasks, max_steps, checksum, episodes_per_task
    )


SUITE_SPECS: dict[str, SuiteSpec] = {
    spec.name: spec
    for spec in (
        _suite_spec("point5", 100, "63de7a54329766843be615c6cae1ea1e72cc8ed13911c0c6d3fe5c82c7197fc1"),
        _suite_spec("ant4", 100, "100530cd4d47ddf9e98402683dba85adf964cc56eb9d3224188fe9553f7b463b"),
        # A fixed map's longest_path_cells: the longest of its 5 tasks' shortest cell paths, in grid steps.
        _suite_spec(
            "u",
            5,
            "1e3a297858444af78ceaacad7613c898399ce9d5bdd7a1524824ca1677b821e0",
            longest_path_cells=6,
            episodes_per_task=20,
        ),
        _suite_spec(
            "medium",
            5,
            "dd00145768a21ebf331971b89310741654197a2587e047b5b6241fc0a3bed770",
            longest_path_cells=10,
            episodes_per_task=20,
        ),
        _suite_spec(
            "large",
            5,
            "0a2b43afd252ef12ccabd52a8fa08a0a9eebcdf61aefed594e7ec7144c04496b",
            longest_path_cells=19,
            episodes_per_task=20,
        ),
        _suite_spec(
            "giant",
            5,
            "4df9aa760368eaff67cf1eacaa310ec710d44730d909dc69eca8833e32166395",
            longest_path_cells=30,
            episodes_per_task=20,
        ),
        # The point on the same maps and tasks (so the same longest paths).
        *(
            _suite_spec(f"point-{source}", 5, checksum, longest_path_cells=cells, episodes_per_task=20)
            for source, cells, checksum in (
                ("u", 6, "6b3c65acc7538fc4f1e3756a05cbcbb8ec69fa48555ee381ac020f2ca22f4c1b"),
                ("medium", 10, "7a977091333d56d982276f0f7445a326751088abad602bbdfc97ccff527f90eb"),
                ("large", 19, "fd0ac7ff6ffe3cd46630d0fc9269095437d4832a9692f72ea0ce3db491d16e7a"),
                ("giant", 30, "a82c62fc914ef2faef52dc2cf33774fdcc33592eb9e6d88133ff0b5d16c28f68"),
            )
        ),
    )
}
"""Every suite, by name, in the order of :data:`~antmaze_hirl.envs.profiles.SUITE_FAMILIES`. Checksums and step
limits are those of ``benchmark_suites.json`` (``scripts/make_suites.py`` regenerates it byte for byte)."""

SUITE_ENTRY_POINT = "antmaze_hirl.sb3_ext.suite_envs:make_suite_env"
"""Entry point of every suite id: the suite env with the body's shipped low level unless one is given."""

SUITE_VECTOR_ENTRY_POINT = "antmaze_hirl.sb3_ext.suite_envs:make_suite_vector_env"
"""``vector_entry_point`` of every suite id: its episodes in lockstep (a string: this layer imports nothing above)."""


def check_suite_name(name: str) -> SuiteSpec:
    """The spec of suite ``name``.

    Raises:
        ValueError: Naming the value and the suites, if ``name`` is no suite.
    """
    if name not in SUITE_SPECS:
        raise ValueError(f"unknown benchmark suite {name!r}; choose one of {list(SUITE_SPECS)}")
    return SUITE_SPECS[name]
