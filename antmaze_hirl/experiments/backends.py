"""Where independent tasks run: one process (serial), a local process pool, or Ray (one machine or a cluster).

The backends of :func:`~antmaze_hirl.experiments.runner.run_experiment`. A task is a module-level function
and its arguments; the driver gets each result back as soon as that task finishes and alone writes
what it must (workers write nothing), so every backend leaves the same files. Nothing here knows what
a task does: the same backends can run low-level seed sweeps or simulated study participants.

Ray is an optional extra (``pip install -e .[ray]``), imported only when the ``ray`` backend runs.
"""

from __future__ import annotations

import argparse
import itertools
import multiprocessing
import os
from collections.abc import Callable, Hashable, Mapping
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from typing import Any, TypeVar

BACKENDS = ("serial", "processes", "ray")
"""The kinds of :class:`Backend`: in this process, in a local process pool, or as Ray tasks."""

RAY_EXTRA = "pip install -e .[ray]"
"""How to install the optional Ray backend (the ``ray`` extra of ``pyproject.toml``)."""

Key = TypeVar("Key", bound=Hashable)


@dataclass(frozen=True)
class Backend:
    """Where the tasks run, and how many at once.

    Attributes:
        kind: ``"serial"`` (one at a time in this process), ``"processes"`` (a pool of fresh local
            interpreters) or ``"ray"`` (one Ray task each).
        jobs: Tasks at once. ``None``: serial 1; processes one per core; ray as many as the Ray
            cluster's CPUs take (a local Ray instance gets ``os.cpu_count()`` CPUs; with ``jobs``,
            ``jobs * cpus_per_task``).
        address: Ray only: the cluster to join (``ray start --head`` prints it); ``None`` reads
            ``RAY_ADDRESS``, and without it starts a local Ray instance.
        cpus_per_task: CPU cores a task uses: its torch threads, and the ``num_cpus`` Ray reserves for
            it. ``None``: the torch thread count of this process.
        max_retries: Ray only: how often a task whose worker died (killed, out of memory, node lost)
            runs again.
    """

    kind: str = "serial"
    jobs: int | None = None
    address: str | None = None
    cpus_per_task: int | None = None
    max_retries: int = 3

    def __post_init__(self) -> None:
        if self.kind not in BACKENDS:
            raise ValueError(f"backend must be one of {list(BACKENDS)}, got {self.kind!r}")
        for name in ("jobs", "cpus_per_task"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
                raise ValueError(f"{name} must be an int >= 1, got {value!r}")
        if self.kind == "serial" and self.jobs not in (None, 1):
            raise ValueError(f"the serial backend runs one task at a time, got jobs={self.jobs}: use processes or ray")
        if self.address is not None and self.kind != "ray":
            raise ValueError(f"an address is for the ray backend only, got address {self.address!r} with {self.kind}")
        if isinstance(self.max_retries, bool) or not isinstance(self.max_retries, int) or self.max_retries < 0:
            raise ValueError(f"max_retries must be an int >= 0, got {self.max_retries!r}")

    def threads(self) -> int:
        """Torch threads of each task: :attr:`cpus_per_task`, else this process's torch thread count."""
        if self.cpus_per_task is not None:
            return self.cpus_per_task
        import torch  # here: the CLI builds a Backend without loading torch

        return torch.get_num_threads()


def add_backend_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``--backend``, ``--jobs``, ``--address`` and ``--cpus-per-trial`` (alias ``--threads``) to ``parser``.

    :func:`backend_settings` turns them into :func:`~antmaze_hirl.experiments.runner.run_experiment`'s keywords.
    """
    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default=None,
        help="where the trials run: serial (one after the other, here), processes (--jobs local processes) or "
        "ray (one Ray task each, on a local Ray instance or the cluster at --address; needs "
        f"{RAY_EXTRA}) (default: processes with --jobs above 1, else serial)",
    )
    parser.add_argument(
        "--jobs",
        type=_positive_int,
        default=None,
        help="trials at once with processes or ray (default: processes one per core, ray what the cluster's CPUs take)",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="with --backend ray: the cluster to join, as 'ray start --head' prints it, e.g. head-node:6379 "
        "(default: $RAY_ADDRESS, else a local Ray instance)",
    )
    parser.add_argument(
        "--cpus-per-trial",
        "--threads",
        dest="cpus_per_trial",
        type=_positive_int,
        default=1,
        help="CPU cores per trial: its torch threads, and the CPUs Ray reserves for it",
    )


def backend_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of :func:`~antmaze_hirl.experiments.runner.run_experiment` set by :func:`add_backend_arguments`."""
    return {"backend": args.backend, "jobs": args.jobs, "address": args.address, "cpus_per_trial": args.cpus_per_trial}


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an int >= 1, got {text!r}")
    return value


def import_ray() -> Any:
    """The ``ray`` module.

    Raises:
        ValueError: One line naming the extra to install, where Ray is not installed.
    """
    try:
        import ray
    except ImportError as error:
        raise ValueError(f"the ray backend needs Ray, which is not installed here: {RAY_EXTRA}") from error
    return ray


def run_tasks(
    function: Callable[..., Any],
    tasks: Mapping[Key, tuple[Any, ...]],
    backend: Backend,
    on_result: Callable[[Key, Any], None],
) -> None:
    """Runs ``function(*args)`` for every ``key: args`` of ``tasks`` on ``backend``.

    ``on_result(key, result)`` runs in this process as each task finishes (in the order of ``tasks`` on
    the serial backend, in order of finishing on the others). ``function`` must be a module-level
    function and its arguments picklable, except on the serial backend. Each task runs with
    :meth:`Backend.threads` torch threads.

    If a task raises, no further task starts; those already running finish (their results are
    handed to ``on_result``), then the first error is raised: a task's own exception as itself, so
    a ``ValueError`` stays one.

    Raises:
        ValueError: The ray backend where Ray is not installed (one line naming the extra).
    """
    runners = {"serial": _run_serial, "processes": _run_in_processes, "ray": _run_on_ray}
    runners[backend.kind](function, tasks, backend, on_result)


def in_worker(threads: int, function: Callable[..., Any], *args: Any) -> Any:
    """Runs ``function(*args)`` with ``threads`` torch threads (what a pool or Ray worker calls)."""
    import torch

    # Ray sets OMP_NUM_THREADS to the task's CPUs, a process pool nothing: set it here, the same for both.
    torch.set_num_threads(threads)
    return function(*args)


def _run_serial(
    function: Callable[..., Any], tasks: Mapping[Key, tuple[Any, ...]], backend: Backend, on_result: Callable
) -> None:
    import torch

    before = torch.get_num_threads()
    try:
        for key, args in tasks.items():
            on_result(key, in_worker(backend.threads(), function, *args))
    finally:
        torch.set_num_threads(before)  # the caller's setting, not the tasks'


def _run_in_processes(
    function: Callable[..., Any], tasks: Mapping[Key, tuple[Any, ...]], backend: Backend, on_result: Callable
) -> None:
    # spawn: a fresh interpreter per worker (no forked MuJoCo or torch thread state).
    pool = ProcessPoolExecutor(backend.jobs or os.cpu_count() or 1, mp_context=multiprocessing.get_context("spawn"))
    threads = backend.threads()
    try:
        # The pool queues what its workers cannot take yet; after an error those are cancelled.
        futures = {pool.submit(in_worker, threads, function, *args): key for key, args in tasks.items()}
        _drain(
            futures,
            finished=lambda running: list(wait(running, return_when=FIRST_COMPLETED).done),
            result=lambda future: future.result(),
            on_result=on_result,
            more=list,
            cancel_waiting=lambda running: [future for future in running if future.cancel()],
        )
    finally:
        pool.shutdown(cancel_futures=True)  # on an interrupt, tasks not started are dropped


def _run_on_ray(
    function: Callable[..., Any], tasks: Mapping[Key, tuple[Any, ...]], backend: Backend, on_result: Callable
) -> None:
    ray = import_ray()
    started_here = not ray.is_initialized()  # a caller's own ray.init() (and its settings) is kept
    if started_here:
        address = backend.address or os.environ.get("RAY_ADDRESS") or None
        # A local instance gets an explicit CPU count: jobs trials' worth, else the machine's cores (and at
        # least one trial's); joining a cluster must not set one (the cluster has its own).
        threads = backend.threads()
        local_cpus = backend.jobs * threads if backend.jobs else max(os.cpu_count() or 1, threads)
        ray.init(
            address=address,
            include_dashboard=False,
            logging_level="WARNING",
            **({} if address else {"num_cpus": local_cpus}),
        )
    try:
        _run_ray_tasks(ray, function, tasks, backend, on_result)
    finally:
        if started_here:
            ray.shutdown()


def _run_ray_tasks(
    ray: Any, function: Callable[..., Any], tasks: Mapping[Key, tuple[Any, ...]], backend: Backend, on_result: Callable
) -> None:
    threads = backend.threads()
    # Ray would keep a task that no node can hold waiting for ever (for an autoscaler to add one).
    largest = max((node["Resources"].get("CPU", 0) for node in ray.nodes() if node["Alive"]), default=0)
    if largest < threads:
        raise ValueError(f"a task's {threads} CPUs (--cpus-per-trial) are more than any Ray node has ({largest:g})")
    # A worker that dies is a system failure, retried; an exception the task raises is not: a seeded
    # task raises it again on every attempt, so a retry would only delay the error.
    submit = ray.remote(num_cpus=threads, max_retries=backend.max_retries, retry_exceptions=False)(in_worker)
    # At most as many tasks in flight as run at once (jobs, else what the cluster's CPUs take now): so that
    # after an error none is left waiting to start, and a grid leaves the rest of a shared cluster free.
    jobs = backend.jobs or max(1, int(ray.cluster_resources().get("CPU", 1) // threads))
    queue = iter(tasks.items())

    def more(count: int = 1) -> list[tuple[Any, Any]]:
        return [(submit.remote(threads, function, *args), key) for key, args in itertools.islice(queue, count)]

    running: dict[Any, Any] = {}
    try:
        running.update(more(jobs))
        _drain(
            running,
            finished=lambda running: ray.wait(list(running), num_returns=1)[0],
            result=lambda ref: _ray_result(ray, ref),
            on_result=on_result,
            more=more,
            cancel_waiting=lambda running: [],
        )
    finally:
        for ref in running:  # an interrupt: nothing keeps running for a driver that is gone
            ray.cancel(ref, force=True)


def _ray_result(ray: Any, ref: Any) -> Any:
    """The task's result; its own exception raised as itself (Ray wraps it, with a remote traceback)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as error:
        raise error.cause from error


def _drain(
    running: dict[Any, Any],
    *,
    finished: Callable[[Mapping[Any, Any]], list[Any]],
    result: Callable[[Any], Any],
    on_result: Callable[[Any, Any], None],
    more: Callable[[], list[tuple[Any, Any]]],
    cancel_waiting: Callable[[Mapping[Any, Any]], list[Any]],
) -> None:
    """Hands each finished task's result to ``on_result`` and starts ``more()`` in its place until none run.

    ``running`` maps each handle (a future, a Ray object ref) to its task's key. After the first error
    nothing more starts and ``cancel_waiting`` drops the tasks queued but not started; the running
    ones finish, then the error is raised.
    """
    error: BaseException | None = None
    while running:
        for handle in finished(running):
            key = running.pop(handle)
            try:
                value = result(handle)
            except Exception as raised:
                if error is None:
                    error = raised
                    for cancelled in cancel_waiting(running):
                        running.pop(cancelled)
                continue  # every error but the first is dropped: the others often repeat it
            on_result(key, value)
            if error is None:
                running.update(more())
    if error is not None:
        raise error
