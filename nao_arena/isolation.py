"""Episodes in a process of their own, watched from outside.

An agent is code someone else wrote. Whatever it does to the process that runs
it (``os._exit``, ``fork``, a SIGALRM handler that ignores the episode's
budget, a loop that never returns, a non-daemon thread) ends at most its own
episode, never the ``run`` command or the trial. :func:`run_isolated` calls a
function in a child forked from this process, so the child starts with this
process's imports and loaded kernels and pays no start-up, and watches it
from here:

- the value (or the exception) comes back through a pipe, pickled;
- the budget is enforced from this process, where the agent cannot block
  signals: ``budget`` seconds of wall clock, plus the time the child spent
  compiling numba kernels (it reports it every :data:`HEARTBEAT` s), plus
  :data:`GRACE` s for the child's own
  :func:`~nao_arena.watchdog.wall_clock_budget` to end the episode cleanly.
  Past that the child and every process it started are killed (SIGKILL to
  its process group) and :class:`~nao_arena.watchdog.EpisodeTimeout` is raised here;
- a child that ends without a value (``os._exit``, a signal, out of memory)
  raises :class:`EpisodeProcessEnded` here, naming its exit status or signal;
- when the call returns, whatever the child left running (threads, forked
  processes) is killed with it; the child dies with this process too
  (Linux: ``PR_SET_PDEATHSIG``), and a process that an agent forks during
  ``act`` ends as soon as ``act`` returns in it (see :meth:`nao_arena.arena.Arena.step`).

Where ``os.fork`` is missing (Windows), or with ``NAO_ARENA_ISOLATION=0``
(e.g. to debug an agent with pdb), the function runs in this process under
the in-process budget only.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import pickle
import select
import signal
import struct
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from nao_arena.kernels import compile_seconds, watch_compiles
from nao_arena.watchdog import EpisodeTimeout

__all__ = [
    "GRACE",
    "HEARTBEAT",
    "EpisodeProcessEnded",
    "die_with_parent",
    "isolation_enabled",
    "run_isolated",
]

T = TypeVar("T")
R = TypeVar("R")

GRACE = 3.0
"""Seconds (wall clock) past its budget that an episode's process gets to stop itself
before it is killed from outside."""

HEARTBEAT = 0.5
"""Interval (s) at which the child reports its kernels' compile time."""

_POLL = 0.25
"""Interval (s) at which this process checks whether the child is still alive."""

_HEADER = struct.Struct("<cQ")
_COMPILE, _VALUE, _RAISED = b"c", b"v", b"x"


class EpisodeProcessEnded(RuntimeError):
    """The process running an episode ended without a result (an agent called ``os._exit``,
    was killed by a signal, or ran out of memory)."""


def isolation_enabled() -> bool:
    """Whether :func:`run_isolated` forks (``os.fork`` exists and ``NAO_ARENA_ISOLATION``
    is not ``0``)."""
    return hasattr(os, "fork") and os.environ.get("NAO_ARENA_ISOLATION", "1") != "0"


def die_with_parent(parent: int | None = None) -> None:
    """Ask the kernel to kill this process (SIGKILL) when its parent ends (Linux only;
    elsewhere nothing). ``parent``: the parent's pid as the parent knew it; if it has
    already ended, this process ends at once."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            pr_set_pdeathsig = 1
            libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    if parent is not None and os.getppid() != parent:
        os._exit(1)


def run_isolated(fn: Callable[[T], R], arg: T, budget: float | None = None) -> R:
    """``fn(arg)`` in a forked child process, watched from here (see the module).

    budget: wall-clock seconds (None or 0: none) after which the child is killed
    (past :data:`GRACE` and its compile time). Raises what ``fn`` raised (KeyboardInterrupt
    included; an exception that cannot be pickled comes back as a RuntimeError with its
    type and message), :class:`~nao_arena.watchdog.EpisodeTimeout` past the budget, and
    :class:`EpisodeProcessEnded` if the child ended without a result.
    """
    if not isolation_enabled():
        return fn(arg)
    if budget is not None and not 0 <= budget < float("inf"):
        raise ValueError(f"budget: expected a number of s >= 0, got {budget}")
    watch_compiles()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()  # or the child prints what this process buffered
    parent = os.getpid()
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child; measured through its results
        os.close(read_end)
        _child(fn, arg, write_end, parent)
    os.close(write_end)
    try:
        return _watch(pid, read_end, budget)
    finally:
        os.close(read_end)
        _end(pid)


# --------------------------------------------------------------------------- the child


def _child(fn: Callable[[Any], Any], arg: Any, fd: int, parent: int) -> None:
    """Run ``fn(arg)``, send its value or exception, then end this process at once."""
    me = os.getpid()
    status = 0
    try:
        os.setpgid(0, 0)  # a group of its own: killing it takes what an agent started
        die_with_parent(parent)
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
        lock = threading.Lock()
        compiled_before = compile_seconds()
        stop = threading.Event()

        def send(kind: bytes, payload: bytes) -> None:
            if os.getpid() != me:
                os._exit(0)  # a fork an agent made: it sends nothing
            with lock:
                _write_all(fd, _HEADER.pack(kind, len(payload)) + payload)

        def heartbeat() -> None:
            last = 0.0
            while not stop.wait(HEARTBEAT):
                spent = compile_seconds() - compiled_before
                if spent != last:
                    last = spent
                    send(_COMPILE, struct.pack("<d", spent))

        threading.Thread(target=heartbeat, name="nao-arena-heartbeat", daemon=True).start()
        try:
            value = fn(arg)
        except BaseException as exc:  # noqa: BLE001 - sent to the parent, raised there
            send(_RAISED, _pickled_exception(exc))
        else:
            send(_VALUE, pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))
        stop.set()
    except BaseException:  # noqa: BLE001 - the parent reports a child without a result
        status = 70
    finally:
        if os.getpid() == me:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
        os._exit(status)  # no atexit, no waiting for threads an agent left behind


def _pickled_exception(exc: BaseException) -> bytes:
    try:
        payload = pickle.dumps(exc, protocol=pickle.HIGHEST_PROTOCOL)
        pickle.loads(payload)
    except Exception:  # noqa: BLE001 - an exception that does not survive pickling
        payload = pickle.dumps(RuntimeError(f"{type(exc).__name__}: {exc}"))
    return payload


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


# --------------------------------------------------------------------------- this side


def _watch(pid: int, fd: int, budget: float | None) -> Any:
    """Read the child's messages until its value or exception arrives, enforcing the
    budget; see :func:`run_isolated`."""
    started = time.monotonic()
    compiled = 0.0
    buffer = b""
    while True:
        wait = _POLL
        if budget:
            left = started + budget + compiled + GRACE - time.monotonic()
            if left <= 0.0:
                raise EpisodeTimeout(budget)
            wait = min(wait, left)
        ready, _, _ = select.select([fd], [], [], wait)
        if not ready:
            if (status := _exited(pid)) is not None:
                raise EpisodeProcessEnded(_ended(status))
            continue
        chunk = os.read(fd, 1 << 16)
        if not chunk:
            status = _exited(pid, block=True)
            raise EpisodeProcessEnded(_ended(status if status is not None else 0))
        buffer += chunk
        while len(buffer) >= _HEADER.size:
            kind, size = _HEADER.unpack_from(buffer)
            if len(buffer) < _HEADER.size + size:
                break
            payload = buffer[_HEADER.size : _HEADER.size + size]
            buffer = buffer[_HEADER.size + size :]
            if kind == _COMPILE:
                (compiled,) = struct.unpack("<d", payload)
            elif kind == _VALUE:
                return pickle.loads(payload)
            else:
                raise pickle.loads(payload)


def _exited(pid: int, block: bool = False) -> int | None:
    """The child's wait status if it has ended (None if it runs); it stays a zombie, so
    that its pid (its process group's id) cannot be reused before :func:`_end`."""
    try:
        info = os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT | (0 if block else os.WNOHANG))
    except ChildProcessError:
        return 0
    if info is None:
        return None
    if info.si_code == os.CLD_EXITED:
        return info.si_status << 8
    return info.si_status  # the signal's number


def _ended(status: int) -> str:
    if os.WIFSIGNALED(status) or (status & 0x7F):
        number = os.WTERMSIG(status) if os.WIFSIGNALED(status) else status & 0x7F
        try:
            name = signal.Signals(number).name
        except ValueError:
            name = f"signal {number}"
        how = f"was killed by {name}"
    else:
        how = f"exited with status {os.WEXITSTATUS(status)}"
    return (
        f"the episode's process {how} before the episode ended (an agent ended it: "
        "os._exit, a signal, or out of memory)"
    )


def _end(pid: int) -> None:
    """Kill the child's process group (the child, and whatever an agent started), then
    reap the child."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.kill(pid, signal.SIGKILL)
    with contextlib.suppress(ChildProcessError):
        os.waitpid(pid, 0)
