"""Where a trial's episodes run: this process, local worker processes, or Ray.

A backend calls one function on each of a list of tasks, somewhere, and hands
every result back to a callback in *this* process as soon as it is available
(in completion order). Everything else (what is already done, the result
files, the progress line, the order of the results tables) is the caller's:
:func:`nao_arena.trials.run_trial` uses the same code path with every
backend, so the same seeds give the same files whichever backend ran them.

``local`` (default): ``workers`` processes of this machine ("spawn"
context), or this process when ``workers == 1``. Nothing to install or start.
The worker processes die with this one (Linux), e.g. when it is killed.

``ray``: each task is a Ray task (``num_cpus=1``). ``address=None`` starts a
private local Ray instance with ``workers`` CPUs (or uses the one this
process is already connected to); an address (``auto``, ``HOST:PORT``,
``ray://HOST:10001``) connects to an existing cluster, whose CPUs then set
the parallelism. Ray is imported only by this backend (``pip install
nao-arena[ray]``) and shut down at the end only if the backend started it.
A cluster that loses a node mid-trial runs that node's episodes again on the
others (up to :data:`RAY_RETRIES` times each): episodes are deterministic, so
the results equal those of an undisturbed run.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from types import ModuleType, TracebackType
from typing import Any, Generic, TypeVar

from nao_arena.isolation import die_with_parent

__all__ = [
    "BACKENDS",
    "RAY_MISSING",
    "Backend",
    "BackendError",
    "LocalBackend",
    "RayBackend",
    "import_ray",
    "make_backend",
]

T = TypeVar("T")
R = TypeVar("R")

BACKENDS: tuple[str, ...] = ("local", "ray")
"""The backend names accepted by :func:`make_backend` (and ``--backend``)."""

RAY_MISSING = "the ray backend needs `pip install nao-arena[ray]`"

RAY_RETRIES = 3
"""How often Ray runs a task again after losing its node or worker process."""

_RESUME = "the episodes finished so far are kept: run the same command again to resume"


class BackendError(RuntimeError):
    """A backend is unavailable (e.g. Ray not installed) or its workers failed."""


class Backend(ABC, Generic[T, R]):
    """Runs ``fn`` on tasks; a context manager (``close`` releases its resources)."""

    name = "backend"

    @abstractmethod
    def run(
        self, fn: Callable[[T], R], tasks: Sequence[T], finished: Callable[[T, R], None]
    ) -> None:
        """Call ``fn(task)`` for every task; ``finished(task, result)`` here, as each ends.

        An exception from ``finished`` (or KeyboardInterrupt) cancels the tasks
        not started yet and propagates.
        """

    def prepare(self) -> None:
        """Get ready to run tasks (e.g. start or connect to Ray); nothing by default."""

    def close(self) -> None:
        """Release what the backend started (nothing by default)."""

    def __enter__(self) -> Backend[T, R]:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class LocalBackend(Backend[T, R]):
    """``workers`` local processes ("spawn"); in this process if ``workers == 1``."""

    name = "local"

    def __init__(self, workers: int = 1) -> None:
        if workers < 1:
            raise ValueError(f"workers: expected >= 1, got {workers}")
        self.workers = workers

    def run(
        self, fn: Callable[[T], R], tasks: Sequence[T], finished: Callable[[T, R], None]
    ) -> None:
        if self.workers == 1 or len(tasks) <= 1:
            for task in tasks:
                finished(task, fn(task))
            return
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(
            max_workers=min(self.workers, len(tasks)),
            mp_context=ctx,
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        ) as pool:
            pending: dict[Future[R], T] = {}
            try:
                pending = {pool.submit(fn, t): t for t in tasks}
                while pending:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        finished(pending.pop(fut), fut.result())
            except BrokenProcessPool as exc:
                raise BackendError(
                    f"a worker process died abruptly (e.g. out of memory); {_RESUME}"
                ) from exc
            except BaseException:
                for fut in pending:
                    fut.cancel()
                # unfinished episodes are discarded anyway: stop their workers now
                # rather than letting them run to the end (e.g. on SIGTERM)
                for proc in list((getattr(pool, "_processes", None) or {}).values()):
                    proc.terminate()
                raise


def import_ray() -> ModuleType:
    """The ``ray`` module; BackendError (:data:`RAY_MISSING`) if it is not installed."""
    try:
        import ray
    except ImportError as exc:
        raise BackendError(RAY_MISSING) from exc
    return ray


def _ray_entry() -> Callable[[bytes, list[str]], Any]:
    """The function a Ray worker runs: ``call(payload, drop)``.

    Defined inside this function so that Ray ships it by value: the worker
    runs it before importing anything of nao_arena. It removes ``drop`` from
    the worker's ``sys.path``, then unpickles ``(fn, task)`` and returns
    ``fn(task)``. Ray puts the driver's working directory first on its
    workers' path; ``drop`` is that directory when the driver's own path
    lacks it, so that a Ray worker imports the same nao_arena as the driver
    (and as a local worker process) even when the trial is started from a
    source checkout of a non-editable install.
    """

    def call(payload: bytes, drop: list[str]) -> Any:
        import os
        import pickle
        import sys

        if drop:
            sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) not in drop]
        fn, task = pickle.loads(payload)
        return fn(task)

    return call


def _shadowing_dirs(address: str | None) -> list[str]:
    """The driver's working directory if it is not on its ``sys.path`` (see _ray_entry)."""
    if address is not None and address.startswith("ray://"):
        return []  # Ray client: workers do not get the driver's directory
    cwd = os.path.abspath(os.curdir)
    return [] if any(os.path.abspath(p or os.curdir) == cwd for p in sys.path) else [cwd]


class RayBackend(Backend[T, R]):
    """Each task a Ray task (1 CPU), on a local Ray instance or the cluster at ``address``.

    ``fn`` and the tasks must be picklable by reference (module-level
    function, importable classes): Ray workers import them like the driver.

    Ray is imported when the backend is made (so a missing Ray fails before
    anything runs) but started or connected to only when there are tasks.
    At most ``window`` tasks (default: twice the cluster's CPUs) are
    submitted at a time, in the order given.
    """

    name = "ray"

    def __init__(
        self, workers: int = 1, address: str | None = None, window: int | None = None
    ) -> None:
        if workers < 1:
            raise ValueError(f"workers: expected >= 1, got {workers}")
        self.workers = workers
        self.address = address
        self.window = window
        self.ray = import_ray()
        self.started = False

    def prepare(self) -> None:
        """Start a local Ray instance, or connect to ``address`` (unless already connected)."""
        ray = self.ray
        if ray.is_initialized():
            return
        quiet: dict[str, Any] = {"logging_level": logging.ERROR, "include_dashboard": False}
        try:
            if self.address is None:
                # "local": a new instance here, even if RAY_ADDRESS names a cluster
                ray.init(address="local", num_cpus=self.workers, **quiet)
            else:
                ray.init(address=self.address, **quiet)
        except Exception as exc:  # noqa: BLE001 - reported with the address
            where = f"the Ray cluster at {self.address}" if self.address else "a local Ray"
            raise BackendError(f"cannot start or connect to {where}: {exc}") from exc
        self.started = True

    def run(
        self, fn: Callable[[T], R], tasks: Sequence[T], finished: Callable[[T, R], None]
    ) -> None:
        if not tasks:
            return
        self.prepare()
        ray = self.ray
        # a task whose node (or worker process) is lost is run again elsewhere, up to
        # RAY_RETRIES times; an episode is deterministic, so its result is the same
        remote = ray.remote(num_cpus=1, max_retries=RAY_RETRIES)(_ray_entry())
        drop = _shadowing_dirs(self.address)
        window = self.window
        if window is None:
            window = 2 * max(1, int(ray.cluster_resources().get("CPU", self.workers)))
        queue = list(reversed(tasks))
        pending: dict[Any, T] = {}
        try:
            while queue or pending:
                while queue and len(pending) < window:
                    task = queue.pop()
                    payload = pickle.dumps((fn, task), protocol=pickle.HIGHEST_PROTOCOL)
                    pending[remote.remote(payload, drop)] = task
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    task = pending.pop(ref)
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayError as exc:
                        raise BackendError(f"a Ray task failed ({exc}); {_RESUME}") from exc
                    finished(task, result)
        except BaseException:
            for ref in pending:
                try:
                    ray.cancel(ref)
                except Exception:  # noqa: BLE001 - best effort on the way out
                    pass
            raise

    def close(self) -> None:
        """If this backend called ``ray.init``: ``ray.shutdown()`` (stops the local
        instance it started, or disconnects from the cluster, which keeps running).
        A Ray session this process had opened before is left as is."""
        if self.started:
            self.ray.shutdown()
            self.started = False


def make_backend(
    name: str = "local", workers: int = 1, address: str | None = None
) -> Backend[Any, Any]:
    """The backend ``name`` (see :data:`BACKENDS`); ValueError for an unknown name or an
    ``address`` without Ray, BackendError if Ray is needed but not installed."""
    if name == "local":
        if address is not None:
            raise ValueError("--address is for the ray backend (use --backend ray)")
        return LocalBackend(workers)
    if name == "ray":
        return RayBackend(workers, address)
    raise ValueError(f"unknown backend {name!r}; choose from {', '.join(BACKENDS)}")
