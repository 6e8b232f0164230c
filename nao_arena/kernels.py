"""The compiled kernels: what compiling them costs, watching it, and compiling ahead of time.

numba compiles a kernel the first time it is called with new argument types and caches
the machine code on disk (``cache=True``: a ``__pycache__`` folder beside the module, or
the folder named by ``NUMBA_CACHE_DIR``); later processes load it in milliseconds. Where
the package ships its kernels precompiled for this Python, numba, platform and CPU
(:mod:`nao_arena.precompiled`), the first run writes them into that cache
(:func:`load_shipped`) and compiles none. Elsewhere it compiles, and this module makes
that visible, fair and as short as two or more cores allow:

- :func:`compile_seconds`: wall-clock seconds (s) this process has spent compiling, a
  compile under way included. The episodes' wall-clock budgets
  (:mod:`nao_arena.watchdog`) leave that time out, so a cold cache or a busy machine
  changes no result.
- Progress: every compile is logged on the logger ``nao_arena.kernels`` (INFO at the
  first, then at most every :data:`PROGRESS_INTERVAL` s: how many kernels, how long,
  which one now; DEBUG for each kernel). The command line shows these on stderr.
- The manifest (``kernels.json`` beside this module): the kernels that episodes of the
  shipped maps compile, per *part* (``core``: every episode; one part per built-in
  agent; ``render``; ``env``: what the envs add), with the kernels each one calls, its
  measured compile time and the shipped maps whose recorded episodes call it.
  :func:`record_manifest` writes it (``python -m nao_arena.kernels record``); a test
  checks that it lists every kernel those episodes use.
- :func:`compile_ahead`: compiles the kernels of some parts in several processes, each
  kernel once its callees are in the cache (so none is compiled twice), longest chain
  first. ``nao-arena compile`` runs it for every part; ``nao-arena run`` and ``trial``
  run it for the parts they need when the cache lacks some of them once the shipped
  kernels are in (:func:`ensure_compiled`), before any budget
  starts (``run`` of a shipped map: only what that map's recorded episodes call,
  :func:`map_part`), and so does the first env of a map in a process
  (:func:`ensure_env_compiled`).
"""

from __future__ import annotations

import functools
import gc
import json
import logging
import os
import re
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    Future,
    ProcessPoolExecutor,
    ThreadPoolExecutor,
    wait,
)
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from importlib import import_module, resources
from multiprocessing import get_context
from typing import Any

__all__ = [
    "PROGRESS_INTERVAL",
    "ahead_enabled",
    "CompileReport",
    "Kernel",
    "Manifest",
    "compile_ahead",
    "ensure_compiled",
    "ensure_env_compiled",
    "compile_count",
    "compile_seconds",
    "load_manifest",
    "load_shipped",
    "map_part",
    "missing_kernels",
    "parse_type",
    "parts_for_agents",
    "preload",
    "record_manifest",
    "type_name",
    "watch_compiles",
]

LOG = logging.getLogger("nao_arena.kernels")

PROGRESS_INTERVAL = 5.0
"""Seconds (s, wall clock) between two progress messages of a compile (lazy or ahead)."""

MANIFEST_FILE = "kernels.json"

CORE = "core"
"""The part every episode compiles (world, statistics, sensing, traffic, predictors)."""

ENV = "env"
"""The part the envs compile (:mod:`nao_arena.environment`: observations, rewards, the
agents of the robots they do not control), beyond ``core``."""

VECTOR = "vector"
"""The part the vector env compiles (:mod:`nao_arena.vector_step`), beyond ``core`` and
``env``."""

MAP_PART = "map:"
"""The prefix of a part that narrows the others to one shipped map (:func:`map_part`)."""


def map_part(name: str) -> str:
    """The part ``map:NAME`` (see :meth:`Manifest.for_parts`): with it, a run of the
    shipped map NAME compiles ahead only the kernels its recorded episodes call (the
    rest, if a rare case calls them, compile when called, outside every budget)."""
    return MAP_PART + name


# --------------------------------------------------------------------------- the clock


class _CompileClock:
    """A numba ``numba:compile`` event listener: time spent compiling (outermost compiles
    only, s), the count of kernels compiled, and progress messages on :data:`LOG`.

    numba compiles under one process-wide lock, so events never interleave."""

    def __init__(self) -> None:
        self.depth = 0
        self.started = 0.0
        self.total = 0.0
        self.count = 0
        self.last_message = -float("inf")
        self.last_compile = -float("inf")
        self.lock = threading.Lock()

    def on_start(self, name: str) -> None:
        now = time.monotonic()
        with self.lock:
            if self.depth == 0:
                self.started = now
            self.depth += 1
            outermost = self.depth == 1
        if outermost and now - self.last_compile >= PROGRESS_INTERVAL:
            # the first compile in a while: a cold or stale cache
            LOG.info(
                "compiling kernels (the first run after installing; cached for later runs) ..."
            )
            self.last_message = now
        elif now - self.last_message >= PROGRESS_INTERVAL:
            self.last_message = now
            LOG.info(
                "compiling kernels: %d compiled in %.0f s (now %s)",
                self.count,
                self.seconds(),
                name,
            )

    def on_end(self, name: str) -> None:
        now = time.monotonic()
        with self.lock:
            self.depth -= 1
            self.count += 1
            if self.depth == 0:
                self.total += now - self.started
            self.last_compile = now
        LOG.debug("compiled %s", name)

    def seconds(self) -> float:
        with self.lock:
            return self.total + (time.monotonic() - self.started if self.depth else 0.0)


_CLOCK = _CompileClock()
_WATCHING = False
_WATCH_LOCK = threading.Lock()


def _kernel_name(data: Mapping[str, Any]) -> str:
    func = getattr(data.get("dispatcher"), "py_func", None)
    if func is None:
        return "?"
    return f"{func.__module__}.{func.__qualname__}"


def watch_compiles() -> None:
    """Start counting this process's numba compiles (idempotent; imports numba)."""
    global _WATCHING
    with _WATCH_LOCK:
        if _WATCHING:
            return
        from numba.core import event

        class Listener(event.Listener):
            def on_start(self, ev: event.Event) -> None:
                _CLOCK.on_start(_kernel_name(ev.data))

            def on_end(self, ev: event.Event) -> None:
                _CLOCK.on_end(_kernel_name(ev.data))

        event.register("numba:compile", Listener())
        _WATCHING = True


def compile_seconds() -> float:
    """Wall-clock seconds (s) this process has spent compiling kernels since
    :func:`watch_compiles` (a compile under way included)."""
    return _CLOCK.seconds()


def compile_count() -> int:
    """How many kernels this process has compiled since :func:`watch_compiles`."""
    return _CLOCK.count


# --------------------------------------------------------------------------- the manifest


@dataclass(frozen=True)
class Kernel:
    """One compiled version of a kernel: ``module``, function ``name``, argument types
    (:func:`type_name`, e.g. ``"Array(float64, 1, 'C', False, aligned=True)"``), the kernels it
    calls (keys), the parts that use it, its compile time (s, its own, without what
    it calls) when the manifest was recorded, and the shipped maps whose recorded
    episodes call or load it (with any agent)."""

    module: str
    name: str
    args: tuple[str, ...]
    calls: tuple[str, ...]
    parts: tuple[str, ...]
    seconds: float
    maps: tuple[str, ...] = ()

    @property
    def key(self) -> str:
        return kernel_key(self.module, self.name, self.args)


def kernel_key(module: str, name: str, args: Sequence[str]) -> str:
    """``module:name(arg, ...)``: a kernel version's name in the manifest."""
    return f"{module}:{name}({', '.join(args)})"


@dataclass(frozen=True)
class Manifest:
    """The kernels by key (see :class:`Kernel`) and the numba version that compiled them."""

    numba: str
    kernels: Mapping[str, Kernel]

    def for_parts(self, parts: Iterable[str]) -> dict[str, Kernel]:
        """The kernels that any of ``parts`` uses, with every kernel they call. A part
        ``map:NAME`` (:func:`map_part`) of a recorded map keeps only the kernels that
        NAME's recorded episodes call (and theirs); of a map not recorded, nothing is
        left out."""
        wanted = {p for p in parts if not p.startswith(MAP_PART)}
        recorded = {m for kernel in self.kernels.values() for m in kernel.maps}
        maps = {p.removeprefix(MAP_PART) for p in parts if p.startswith(MAP_PART)} & recorded
        todo = [
            k
            for k, kernel in self.kernels.items()
            if wanted & set(kernel.parts) and (not maps or maps & set(kernel.maps))
        ]
        out: dict[str, Kernel] = {}
        while todo:
            key = todo.pop()
            if key in out or key not in self.kernels:
                continue
            out[key] = self.kernels[key]
            todo.extend(self.kernels[key].calls)
        return out


def manifest_to_json(manifest: Manifest) -> str:
    """The manifest as JSON text (sorted, one kernel per entry)."""
    kernels = {
        key: {
            "module": k.module,
            "name": k.name,
            "args": list(k.args),
            "calls": sorted(k.calls),
            "parts": sorted(k.parts),
            "seconds": round(k.seconds, 3),
            "maps": sorted(k.maps),
        }
        for key, k in sorted(manifest.kernels.items())
    }
    return json.dumps({"numba": manifest.numba, "kernels": kernels}, indent=1) + "\n"


def manifest_from_json(text: str) -> Manifest:
    """Read :func:`manifest_to_json`'s text."""
    data = json.loads(text)
    kernels = {
        key: Kernel(
            module=v["module"],
            name=v["name"],
            args=tuple(v["args"]),
            calls=tuple(v["calls"]),
            parts=tuple(v["parts"]),
            seconds=float(v["seconds"]),
            maps=tuple(v.get("maps", ())),
        )
        for key, v in data["kernels"].items()
    }
    return Manifest(numba=str(data["numba"]), kernels=kernels)


@functools.cache
def load_manifest() -> Manifest:
    """The shipped manifest (an empty one when the file is missing), read once."""
    try:
        text = resources.files("nao_arena").joinpath(MANIFEST_FILE).read_text(encoding="utf-8")
    except FileNotFoundError:
        return Manifest(numba="", kernels={})
    return manifest_from_json(text)


def parts_for_agents(agents: Iterable[str]) -> list[str]:
    """The manifest parts an episode with these agents (built-in names or references)
    compiles: ``core`` and each built-in agent's own part."""
    from nao_arena.agent import BUILTIN_AGENTS

    parts = [CORE]
    for agent in agents:
        if agent in BUILTIN_AGENTS and agent not in parts:
            parts.append(agent)
    return parts


def type_name(numba_type: Any) -> str:
    """The text the manifest holds for a numba type: its repr, but for the types whose
    repr names a Python class without its module (a named tuple such as
    :class:`nao_arena.stopping.Knowledge`, an ``IntEnum``, a structure of compiled
    code such as :class:`nao_arena.period.PeriodInputs`), which are written as
    ``named_tuple("module:Class", (fields ...))``, ``int_enum("module:Class",
    dtype)`` and ``struct_ref("module:TypeClass", (("field", type), ...))``, and a typed
    list of them, ``ListType(item)``. :func:`parse_type` reads every such text back."""
    from numba.core import types

    if isinstance(numba_type, types.BaseNamedTuple):
        named: Any = numba_type  # numba's own stubs lack the attributes
        fields = ", ".join(type_name(t) for t in named.types)
        comma = "," if len(named.types) == 1 else ""
        return f'named_tuple("{_class_path(named.instance_class)}", ({fields}{comma}))'
    if isinstance(numba_type, types.ListType):
        return f"ListType({type_name(numba_type.item_type)})"
    if isinstance(numba_type, types.IntEnumMember):
        return f'int_enum("{_class_path(numba_type.instance_class)}", {numba_type.dtype!r})'
    if isinstance(numba_type, types.StructRef):
        fields = ", ".join(
            f'("{name}", {type_name(t)})' for name, t in numba_type.field_dict.items()
        )
        return f'struct_ref("{_class_path(type(numba_type))}", ({fields},))'
    return repr(numba_type)


def _class_path(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _import_class(path: str) -> Any:
    module, _, qualname = path.partition(":")
    found: Any = import_module(module)
    for part in qualname.split("."):
        found = getattr(found, part)
    return found


@functools.cache
def parse_type(text: str) -> Any:
    """The numba type whose :func:`type_name` is ``text`` (the texts the manifest holds:
    arrays, tuples, named tuples, IntEnums, structures and scalars)."""
    # Literal[int](0), Literal[bool](True): the type of a constant argument
    text = re.sub(r"Literal\[(?:int|bool)\]\((-?\d+|True|False)\)", r"literal(\1)", text)
    return eval(text, {"__builtins__": {}}, _type_names())  # the package's own file


def _named_tuple(path: str, fields: tuple[Any, ...]) -> Any:
    from numba.core import types

    return types.BaseTuple.from_types(fields, _import_class(path))


def _struct_ref(path: str, fields: tuple[tuple[str, Any], ...]) -> Any:
    return _import_class(path)(list(fields))


def _int_enum(path: str, dtype: Any) -> Any:
    from numba.core import types

    return types.IntEnumMember(_import_class(path), dtype)


@functools.cache
def _type_names() -> dict[str, Any]:
    """The names a numba type's :func:`type_name` uses (numba.core.types, bool, literal,
    named_tuple, int_enum, struct_ref)."""
    from numba.core import types

    names = {name: getattr(types, name) for name in dir(types) if not name.startswith("_")}
    names.update(
        bool=types.boolean,
        literal=types.literal,
        named_tuple=_named_tuple,
        int_enum=_int_enum,
        struct_ref=_struct_ref,
    )
    return names


def _dispatcher(kernel: Kernel) -> Any:
    return getattr(import_module(kernel.module), kernel.name)


def _signature(kernel: Kernel) -> tuple[Any, ...]:
    return tuple(parse_type(a) for a in kernel.args)


def _cache_holds(kernel: Kernel) -> bool:
    """Whether numba's cache holds this kernel version, compiled by this numba for this
    machine and this source (its index is read; nothing is loaded or compiled). A stale
    manifest entry, whose function is gone (a source edited since the manifest was
    recorded), counts as held: there is nothing to compile ahead for it."""
    try:
        dispatcher = _dispatcher(kernel)
    except (ImportError, AttributeError):
        LOG.debug("stale manifest entry %s: not compiled ahead", kernel.key)
        return True
    cache: Any = getattr(dispatcher, "_cache", None)
    try:
        key = cache._index_key(_signature(kernel), dispatcher.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # an unknown numba version or no cache: take it as missing
        return False


def ahead_enabled() -> bool:
    """Whether ``run``, ``trial`` and the test suite compile ahead of time when the cache
    lacks kernels: yes unless the environment sets ``NAO_ARENA_COMPILE_AHEAD=0`` (then
    every kernel compiles in the process that first calls it)."""
    return os.environ.get("NAO_ARENA_COMPILE_AHEAD", "1").strip() != "0"


def missing_kernels(parts: Iterable[str], manifest: Manifest | None = None) -> list[str]:
    """The keys of the kernels of ``parts`` that the cache lacks. Only the kernels that no
    other one calls are looked up: a caller's cached code holds its linked callees' and
    loads its shared callees (:mod:`nao_arena.shared_code`); one whose shared callee has
    left the cache is compiled again when it is loaded."""
    manifest = load_manifest() if manifest is None else manifest
    kernels = manifest.for_parts(parts)
    called = {c for k in kernels.values() for c in k.calls}
    roots = [k for key, k in kernels.items() if key not in called]
    return [k.key for k in roots if not _cache_holds(k)]


def preload(parts: Iterable[str]) -> int:
    """Load the kernels of ``parts`` into this process now (from the cache, or compiled
    if the cache lacks them), so that the episodes that follow, and the processes forked
    from this one to run them (:mod:`nao_arena.isolation`), start warm. Only the kernels
    that no other one calls are loaded (with the callees their code holds or shares); a
    stale manifest entry is skipped (it compiles when called). Returns how many were
    loaded."""
    kernels = load_manifest().for_parts(parts)
    called = {c for k in kernels.values() for c in k.calls}
    loaded = 0
    for key, kernel in kernels.items():
        if key in called or key in _PRELOADED:
            continue
        try:
            _dispatcher(kernel).compile(_signature(kernel))
        except Exception:  # noqa: BLE001 - a stale manifest entry compiles when called
            LOG.debug("cannot preload %s", key)
        _PRELOADED.add(key)
        loaded += 1
    return loaded


_PRELOADED: set[str] = set()
"""The manifest keys :func:`preload` has loaded in this process."""


# --------------------------------------------------------------------------- compiling ahead


@dataclass(frozen=True)
class CompileReport:
    """What :func:`compile_ahead` did: kernels compiled (or loaded from the cache),
    those that failed or were not reached (key: error), processes, wall-clock seconds
    (s) and the processes' CPU seconds (s)."""

    kernels: int
    failed: Mapping[str, str]
    jobs: int
    seconds: float
    cpu_seconds: float = 0.0

    @property
    def compiled(self) -> int:
        """The kernels now in the cache: compiled or loaded, not failed."""
        return self.kernels - len(self.failed)

    def summary(self, note: str = "") -> str:
        """One line: how many of the kernels are cached, in how long (then ``note``), and
        what the others met (the first error: on a numba the package does not support,
        every kernel fails alike)."""
        line = (
            f"{self.compiled} of {self.kernels} kernels compiled or loaded in "
            f"{self.seconds:.0f} s ({self.cpu_seconds:.0f} s of CPU) with {self.jobs} "
            f"process{'es' if self.jobs != 1 else ''}{note}"
        )
        if self.failed:
            first = next(iter(self.failed.values())).splitlines()[0][:200]
            line += f"; {len(self.failed)} left to compile when called (first error: {first})"
        return line


def _compile_one(module: str, name: str, args: tuple[str, ...]) -> tuple[float, str | None]:
    """In a worker process: compile one kernel version into the cache (its callees are
    there already). Returns (CPU seconds, error or None)."""
    started = time.process_time()
    kernel = Kernel(module, name, args, (), (), 0.0)
    try:
        _dispatcher(kernel).compile(_signature(kernel))
    except Exception as exc:  # a stale manifest entry: the kernel compiles when called
        return time.process_time() - started, f"{type(exc).__name__}: {exc}"
    finally:
        _settle_garbage()
    return time.process_time() - started, None


def _worker_setup() -> None:
    """Initializer of a compile worker, before numba is imported there: two costs of
    numba's own that its output does not depend on, taken off (the worker only
    compiles kernels into the cache).

    - Typing error messages without colours. numba writes one for every overload that
      does not match while it types a call (some 45,000 in a NAO run's compile) and,
      with colorama installed, styles each through colorama's stream wrappers: 4 to 5 %
      of the compile.
    - Faster comparisons of compile flags (:func:`_quick_flags`): about 5 %."""
    os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")
    _quick_flags()


def _quick_flags() -> None:
    """numba looks up every overload it types in a cache keyed by the caller's compile
    flags (a ``TargetConfig``). All flags hash alike (the hash is of the option names),
    so each lookup compares flags, and each comparison builds both flags' full value
    dicts through one property call per option: 200,000 comparisons, 2 s of a NAO run's
    compile. Here the value dicts are built straight from the stored values, and two
    flags of one class whose stored values are equal are equal at once. The results are
    numba's: the same values, the same hash, the same equality, checked on a few flags
    before the change is kept (numba's own stay where they differ, or where numba's
    ``TargetConfig`` is not laid out as expected)."""
    from numba.core import targetconfig
    from numba.core.compiler import Flags

    config: Any = targetconfig.TargetConfig
    if not ("_values" in getattr(config, "__slots__", ()) and hasattr(config, "values")):
        return

    def values(self: Any) -> dict[str, Any]:
        get = self._values.get
        return {name: get(name, option.default) for name, option in self.options.items()}

    def equal(self: Any, other: Any) -> Any:
        if type(self) is type(other) and self._values == other._values:
            return True
        if isinstance(other, config):
            return values(self) == values(other)
        return NotImplemented

    def flags_hash(self: Any) -> int:
        return hash(tuple(sorted(self.options)))  # numba's: sorted(self.values()) is the names

    samples: list[Any] = [Flags(), Flags(), Flags()]
    samples[1].error_model = "numpy"
    samples[1].no_cpython_wrapper = True
    samples[2].no_cpython_wrapper = False  # set to its default: equal to the first

    def answers() -> list[Any]:
        return [(list(f.values().items()), hash(f)) for f in samples] + [
            a == b for a in samples for b in samples
        ]

    numba_answers = answers()
    numba_own = config.values, config.__eq__, config.__hash__
    config.values, config.__eq__, config.__hash__ = values, equal, flags_hash
    if answers() != numba_answers:
        config.values, config.__eq__, config.__hash__ = numba_own


def _settle_garbage() -> None:
    """In a worker process, after each kernel: collect the garbage of that compile, then
    freeze what is left (numba's types, templates and compiled code, which live as long
    as the process). Python's full collections then no longer walk that growing heap
    again and again: without this they took about a tenth of the worker's CPU time, and
    memory stays where it was (each collection sees only one kernel's objects)."""
    gc.collect()
    gc.freeze()


def _chain_seconds(kernels: Mapping[str, Kernel]) -> dict[str, float]:
    """Per kernel: its compile time plus that of the longest chain of kernels that wait
    for it (its callers, theirs, ...), s: the order in which to start them."""
    callers: dict[str, list[str]] = {key: [] for key in kernels}
    for key, k in kernels.items():
        for c in k.calls:
            if c in callers:
                callers[c].append(key)
    chain: dict[str, float] = {}

    def visit(key: str) -> float:
        if key not in chain:
            chain[key] = 0.0  # a cycle (recursion) counts once
            chain[key] = kernels[key].seconds + max((visit(c) for c in callers[key]), default=0.0)
        return chain[key]

    for key in kernels:
        visit(key)
    return chain


def compile_ahead(
    parts: Iterable[str],
    jobs: int | None = None,
    manifest: Manifest | None = None,
    on_done: Callable[[int, int, str], None] | None = None,
) -> CompileReport:
    """Compile the kernels of ``parts`` into the cache with ``jobs`` processes (default:
    every core), each kernel after the kernels it calls; ``on_done(done, total, key)``
    after each. Kernels already cached are only loaded (milliseconds). Progress (at
    most every :data:`PROGRESS_INTERVAL` s) and the summary
    (:meth:`CompileReport.summary`) are logged on :data:`LOG` (INFO)."""
    parts = list(parts)
    manifest = load_manifest() if manifest is None else manifest
    kernels = manifest.for_parts(parts)
    jobs = max(1, jobs or os.cpu_count() or 1)
    started = time.monotonic()
    waiting = {key: {c for c in k.calls if c in kernels and c != key} for key, k in kernels.items()}
    priority = _chain_seconds(kernels)
    failed: dict[str, str] = {}
    done = 0
    total = len(kernels)
    if missing_kernels(parts, manifest):
        LOG.info("compiling %d kernels in %d processes ...", total, jobs)
    else:  # nao-arena compile, with every kernel cached: each is loaded, compiled if stale
        LOG.info("checking the %d cached kernels in %d processes ...", total, jobs)
    progress = _AheadProgress(started)
    cpu = 0.0
    context = get_context("spawn")  # no state of this process's numba is shared
    try:
        pool = ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_worker_setup)
    except (OSError, ValueError) as exc:  # no processes here: compile when called
        LOG.debug("cannot start processes (%s): kernels compile when first called", exc)
        return _reported(CompileReport(len(kernels), dict.fromkeys(kernels, str(exc)), 0, 0.0))
    with pool:
        running: dict[Future[tuple[float, str | None]], str] = {}
        while waiting or running:
            ready = sorted(
                (key for key, w in waiting.items() if not w), key=lambda key: -priority[key]
            )
            for key in ready[: max(0, jobs - len(running))]:
                k = kernels[key]
                running[pool.submit(_compile_one, k.module, k.name, k.args)] = key
                del waiting[key]
            if not running:  # a cycle of calls: start the longest one
                key = max(waiting, key=lambda key: priority[key])
                waiting[key] = set()
                continue
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                key = running.pop(future)
                try:
                    seconds, error = future.result()
                except BrokenProcessPool as exc:  # a worker died: the rest compile when called
                    failed.update(dict.fromkeys([key, *waiting, *running.values()], str(exc)))
                    LOG.debug("a compile process died (%s)", exc)
                    return _reported(
                        CompileReport(total, failed, jobs, time.monotonic() - started, cpu)
                    )
                cpu += seconds
                if error is not None:
                    failed[key] = error
                    LOG.debug(
                        "could not compile %s ahead of time (%s); it compiles when first called",
                        key,
                        error,
                    )
                done += 1
                for w in waiting.values():
                    w.discard(key)
                LOG.debug("[%d/%d] %s", done, total, key)
                progress(done, total, key)
                if on_done is not None:
                    on_done(done, total, key)
    return _reported(CompileReport(total, failed, jobs, time.monotonic() - started, cpu))


class _AheadProgress:
    """The progress of :func:`compile_ahead` on :data:`LOG` (INFO): kernels done of all
    and seconds so far, at most every :data:`PROGRESS_INTERVAL` s (s, wall clock)."""

    def __init__(self, started: float) -> None:
        self.started = started
        self.shown = started

    def __call__(self, done: int, total: int, key: str) -> None:
        now = time.monotonic()
        if done == total or now - self.shown < PROGRESS_INTERVAL:
            return  # the summary tells the end
        self.shown = now
        LOG.info(
            "compiled %d/%d kernels in %.0f s (last: %s)",
            done,
            total,
            now - self.started,
            key.partition("(")[0],
        )


def _reported(report: CompileReport) -> CompileReport:
    """``report``, its summary logged on :data:`LOG` (INFO)."""
    LOG.info("%s", report.summary(" (cached for later runs)" if report.compiled else ""))
    return report


def ensure_compiled(
    parts: Iterable[str],
    jobs: int | None = None,
    on_done: Callable[[int, int, str], None] | None = None,
) -> CompileReport | None:
    """When :func:`ahead_enabled` and the cache lacks some kernels of ``parts``: the
    shipped precompiled ones written into it (:func:`load_shipped`), then
    :func:`compile_ahead` for ``parts`` if it still lacks some; None when nothing was
    compiled."""
    parts = list(parts)
    if not ahead_enabled() or not _missing_after_install(parts):
        return None
    return compile_ahead(parts, jobs, on_done=on_done)


def load_shipped(parts: Iterable[str]) -> int:
    """Write the shipped precompiled kernels of ``parts`` that the cache lacks into it
    (:func:`nao_arena.precompiled.install`); how many were written."""
    from nao_arena import precompiled

    return precompiled.install(load_manifest().for_parts(parts)).written


def _missing_after_install(parts: Sequence[str]) -> list[str]:
    """:func:`missing_kernels` of ``parts``, after the shipped precompiled kernels the
    cache lacked were written into it (:func:`load_shipped`)."""
    missing = missing_kernels(parts)
    if missing and load_shipped(parts):
        missing = missing_kernels(parts)
    return missing


def ensure_env_compiled(map_source: object, vector: bool = False) -> None:
    """Before an env of ``map_source`` (a shipped map's name or a map file) first runs in
    this process: when the cache lacks some of the kernels of ``core`` and ``env``, and
    of ``vector`` for a vector env (of a shipped map, only what its recorded episodes
    call, :func:`map_part`) and :func:`ahead_enabled`, write the shipped precompiled
    ones into it (:func:`load_shipped`), then compile what it still lacks ahead in every
    core, not one by one in this process. Once per process and map. The compile runs in
    a Python process of its own (:func:`_compile_in_subprocess`), so that the processes
    it starts never import the script that made the env, whether or not it guards its
    code with ``if __name__ == "__main__"``. Not in a daemonic process (the workers of
    Stable-Baselines3's ``SubprocVecEnv``, for one: each would compile the same kernels
    at once); any failure leaves the kernels to compile when they are called."""
    from multiprocessing import current_process

    from nao_arena.maps import available_maps

    key = f"{map_source}, vector" if vector else str(map_source)
    with _ENV_LOCK:
        if key in _ENV_ENSURED:
            return
        _ENV_ENSURED.add(key)
    if current_process().daemon or not ahead_enabled():
        return
    parts = [CORE, ENV, *([VECTOR] if vector else [])]
    if isinstance(map_source, str) and map_source in available_maps():
        parts.append(map_part(map_source))
    try:
        if _missing_after_install(parts):
            LOG.info("compiling the kernels of an env of %s ahead ...", key)
            _compile_in_subprocess(parts)
    except Exception as exc:  # noqa: BLE001 - the kernels compile when called instead
        LOG.debug("could not compile the env's kernels ahead (%s)", exc)


def _compile_in_subprocess(parts: Sequence[str]) -> None:
    """:func:`compile_ahead` of ``parts`` in a new Python process (``python -c``: no
    script of the caller's to import again), waiting for it. What it logs on
    :data:`LOG` (progress, the summary) is logged again here, line by line as it comes;
    the rest of its output is discarded."""
    import subprocess
    import sys

    with subprocess.Popen(
        [sys.executable, "-c", _SUBPROCESS_CODE, *parts],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        encoding="utf-8",
        errors="replace",
    ) as process:
        assert process.stdout is not None
        for line in process.stdout:
            if line.strip():
                LOG.info("%s", line.rstrip())


_SUBPROCESS_CODE = """
import logging, sys
from nao_arena.kernels import LOG, compile_ahead
LOG.addHandler(logging.StreamHandler(sys.stdout))
LOG.setLevel(logging.INFO)
LOG.propagate = False
compile_ahead(sys.argv[1:])
"""
"""What :func:`_compile_in_subprocess` runs: :func:`compile_ahead` of the parts in its
arguments, with :data:`LOG`'s messages on stdout, one per line."""


_ENV_ENSURED: set[str] = set()
"""The maps :func:`ensure_env_compiled` has seen in this process."""
_ENV_LOCK = threading.Lock()


# --------------------------------------------------------------------------- recording


def _loaded_kernels() -> dict[str, tuple[Any, Any, Any]]:
    """key -> (dispatcher, signature, compile result) of every kernel version compiled
    or loaded in this process, from nao_arena's modules."""
    import sys

    from numba.core.dispatcher import Dispatcher

    out: dict[str, tuple[Any, Any, Any]] = {}
    for module_name, module in list(sys.modules.items()):
        if not module_name.startswith("nao_arena") or module is None:
            continue
        for name, value in list(vars(module).items()):
            if not isinstance(value, Dispatcher) or value.__module__ != module_name:
                continue
            for sig, cres in value.overloads.items():
                key = kernel_key(module_name, name, [type_name(t) for t in sig])
                out[key] = (value, sig, cres)
    return out


def _record_map(part: str, name: str, steps: int) -> dict[str, Any]:
    """In a process of its own, with the part's cache (empty for the part's first map):
    run ``steps`` steps of map ``name`` with the agent ``part`` (``core``: the ``goal``
    agent; ``render``: a few frames to a GIF; ``env``: the env of the map, with random
    actions), and return the kernels compiled or loaded, each with what it calls (when
    compiled here) and its own compile time."""
    import tempfile

    from numba.core import event

    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    own: dict[str, float] = {}
    stack: list[list[Any]] = []

    class Timer(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            stack.append([ev.data, time.perf_counter(), 0.0])

        def on_end(self, ev: event.Event) -> None:
            data, t0, inner = stack.pop()
            spent = time.perf_counter() - t0
            func = data["dispatcher"].py_func
            key = kernel_key(func.__module__, func.__name__, [type_name(t) for t in data["args"]])
            own[key] = own.get(key, 0.0) + spent - inner
            if stack:
                stack[-1][2] += spent

    event.register("numba:compile", Timer())
    if part in (ENV, VECTOR):
        _env_episode(name, steps, vector=part == VECTOR)
        return _kernels_loaded_here(own)
    agent = "goal" if part in (CORE, "render") else part
    arena = Arena(load_map(name), ArenaOptions(agent=agent))
    if part == "render":
        from nao_arena.render import record_episode

        arena.reset(0)
        with tempfile.TemporaryDirectory() as folder:
            record_episode(arena, os.path.join(folder, "x.gif"), max_steps=steps)
    else:
        arena.run(0, max_steps=steps)
    return _kernels_loaded_here(own)


def _env_episode(name: str, steps: int, vector: bool = False) -> None:
    """``steps`` steps of the env of map ``name`` (its default options) with random
    actions (seeded), or (``vector``) of a vector env of two copies of it; a map the env
    does not take is left out."""
    import numpy as np

    from nao_arena.environment import NaoArenaParallelEnv
    from nao_arena.vector import VectorEnv

    try:
        env = NaoArenaParallelEnv(name, keep_finished=vector)
    except ValueError as exc:  # e.g. a map with no robot to control
        LOG.debug("no env for %s: %s", name, exc)
        return
    rng = np.random.default_rng(0)
    if vector:
        vec = VectorEnv.of_envs([env, NaoArenaParallelEnv(name, keep_finished=True)], seed=0)
        vec.reset()
        for _ in range(steps):
            vec.step(rng.uniform(-1.0, 1.0, vec.action_space.shape))
        return
    env.reset(seed=0)
    for _ in range(steps):
        if not env.agents:
            break
        env.step({a: rng.uniform(-1.0, 1.0, 2) for a in env.agents})


def _kernels_loaded_here(own: Mapping[str, float]) -> dict[str, Any]:
    """The kernels compiled or loaded in this process, each with what it calls (when
    compiled here) and ``own[key]``, its own compile time (s)."""
    from nao_arena.shared_code import shared_callees

    loaded = _loaded_kernels()
    by_library = {id(cres.library): key for key, (_, _, cres) in loaded.items()}
    out: dict[str, Any] = {}
    for key, (_, sig, cres) in loaded.items():
        # what it calls: the callees linked into its code, and those it shares
        linked = [*getattr(cres.library, "_linking_libraries", ()), *shared_callees(cres.library)]
        calls = sorted({by_library[id(lib)] for lib in linked if id(lib) in by_library} - {key})
        mod, _, rest = key.partition(":")
        out[key] = {
            "module": mod,
            "name": rest.partition("(")[0],
            "args": [type_name(t) for t in sig],
            "calls": calls,
            "seconds": own.get(key, 0.0),
        }
    return out


RECORD_PARTS = (
    CORE,
    "nao",
    "ao",
    "vo",
    "orca",
    "cbf",
    "goal",
    "lane",
    "social_force",
    "render",
    ENV,
    VECTOR,
)
"""The parts :func:`record_manifest` records."""


def record_manifest(
    maps: Sequence[str] | None = None, steps: int = 30, jobs: int | None = None
) -> Manifest:
    """Record the manifest: each part over ``maps`` (default: every shipped map; render:
    one map), each map in a process of its own with the part's cache (a temporary
    ``NUMBA_CACHE_DIR``, empty for its first map: every kernel of the part compiles
    once, and each map's process loads or compiles exactly what its episode calls).
    Kernels that ``core`` uses belong to ``core`` only."""
    import tempfile

    import numba

    from nao_arena.maps import available_maps

    maps = list(maps or available_maps())
    jobs = max(1, jobs or os.cpu_count() or 1)
    found: dict[str, dict[str, Any]] = {}

    def record(part: str) -> list[tuple[str, dict[str, Any]]]:
        cache = tempfile.mkdtemp(dir=root)
        part_maps = maps[:1] if part == "render" else maps
        out = []
        for name in part_maps:  # a process per map, all with the part's cache
            with ProcessPoolExecutor(
                max_workers=1,
                mp_context=get_context("spawn"),
                initializer=_use_cache,
                initargs=(cache,),
            ) as pool:
                out.append((name, pool.submit(_record_map, part, name, steps).result()))
        return out

    with tempfile.TemporaryDirectory() as root, ThreadPoolExecutor(jobs) as threads:
        results = dict(zip(RECORD_PARTS, threads.map(record, RECORD_PARTS), strict=True))
    core = {key for _, kernels in results[CORE] for key in kernels}
    for part, per_map in results.items():
        for name, kernels in per_map:
            for key, entry in kernels.items():
                item = found.setdefault(
                    key, {**entry, "parts": set(), "calls": set(), "maps": set()}
                )
                if part == CORE or key not in core:
                    item["parts"].add(part)
                item["calls"].update(entry["calls"])
                item["seconds"] = max(item["seconds"], entry["seconds"])
                item["maps"].add(name)
    # a kernel whose argument types cannot be named (function pointers) compiles when called
    found = {key: v for key, v in found.items() if _nameable(v["args"])}
    kernels = {
        key: Kernel(
            module=v["module"],
            name=v["name"],
            args=tuple(v["args"]),
            calls=tuple(sorted(c for c in v["calls"] if c in found)),
            parts=tuple(sorted(v["parts"])),
            seconds=v["seconds"],
            maps=tuple(sorted(v["maps"])),
        )
        for key, v in found.items()
    }
    return Manifest(numba=numba.__version__, kernels=kernels)


def _nameable(args: Iterable[str]) -> bool:
    """Whether every type name of ``args`` (:func:`type_name`) reads back as that type."""
    try:
        return all(type_name(parse_type(a)) == a for a in args)
    except Exception:
        return False


def _use_cache(folder: str) -> None:
    """Worker initializer: numba caches into ``folder``, and what the worker's episode
    calls compiles there, in the worker (an env would compile ahead in other processes;
    a shipped precompiled kernel would be loaded, without its callees or compile time)."""
    os.environ["NUMBA_CACHE_DIR"] = folder
    os.environ["NAO_ARENA_COMPILE_AHEAD"] = "0"
    os.environ["NAO_ARENA_PRECOMPILED"] = "0"
    import numba

    numba.config.reload_config()


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m nao_arena.kernels record [--steps N]``: write the manifest beside
    this module."""
    import argparse
    from pathlib import Path

    from nao_arena.atomic import atomic_write_text

    parser = argparse.ArgumentParser(prog="python -m nao_arena.kernels")
    parser.add_argument("command", choices=["record"])
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=None)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    manifest = record_manifest(steps=args.steps, jobs=args.jobs)
    path = Path(__file__).with_name(MANIFEST_FILE)
    atomic_write_text(path, manifest_to_json(manifest))
    print(f"wrote {path}: {len(manifest.kernels)} kernels")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
