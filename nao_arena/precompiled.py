"""Kernels compiled ahead of time and shipped with the package: a first run loads them
into numba's cache instead of compiling them.

What is shipped
    numba's cache entries (the machine code and what numba needs to load it) of every
    kernel of the manifest (:mod:`nao_arena.kernels`), compiled for a CPU level of the
    architecture rather than for the machine that built them (:data:`TARGETS`: on
    x86-64, ``x86-64-v2``, the instructions of CPUs with SSE4.2, Intel's since 2008 and
    AMD's since 2011; as fast as code compiled for this Xeon in ``bench_decisions``, where the
    architecture's bare baseline was 5 % slower), one zip file per Python version,
    numba version and platform: ``nao_arena/precompiled_kernels/<tag>.zip``
    (:func:`bundle_tag`). A zip holds ``index.json`` (the tag, the CPU level and the
    CPU features it needs, the digest of the sources it was compiled from, and per
    entry the kernel, its argument types and numba's hash of its bytecode) and one
    data file per entry, as numba wrote it. No compiler is needed to install the
    package: the files are data.

When they are used
    Before the kernels of a run, a trial or an env are compiled ahead
    (:func:`nao_arena.kernels.ensure_compiled`), the entries the cache lacks are
    written into numba's cache (:func:`install`); and whenever the kernels' cache
    misses a kernel that is shipped (one first called from Python, for one), its entry
    is written then (:func:`install_kernel`). Entries are written as this process's
    numba would have written them (the index key names this machine's CPU, which has
    every feature the code needs; the stamp is the installed source file's). Only a zip built from
    exactly these sources is used (:func:`source_digest`, every module of the package):
    a kernel's code holds its callees' code and the constants it read, so one changed
    module can make any entry stale. With another Python, numba or platform, a CPU
    without the features, changed sources, or ``NAO_ARENA_PRECOMPILED=0``, nothing is
    written and the kernels compile as before. Results are the same either way: the
    code computes the same bits (no fast-math anywhere, so no fused multiply-adds; the
    golden trajectories run on it).

How they are made
    ``python -m nao_arena.precompiled build`` (:func:`build`): every kernel of the
    manifest compiled ahead in a new, empty cache in a process of its own, for the
    CPU level, then packed. Run it with each Python version shipped, after any
    change of the package's modules (a test fails while a shipped zip is stale).
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import platform
import sys
import tempfile
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path
from typing import Any, cast

__all__ = [
    "FORMAT",
    "MAPPED_PACKAGES",
    "SHIPPED_PYTHONS",
    "TARGETS",
    "Target",
    "BundleInfo",
    "InstallReport",
    "build",
    "bundle_path",
    "bundle_tag",
    "enabled",
    "install",
    "install_kernel",
    "missing_features",
    "read_info",
    "source_digest",
    "target",
]

LOG = logging.getLogger("nao_arena.kernels")

FORMAT = 1
"""The layout of a zip's ``index.json`` this module reads and writes."""

BUNDLE_FOLDER = Path(__file__).with_name("precompiled_kernels")
"""Where the zips are shipped (package data)."""

INDEX = "index.json"


@dataclass(frozen=True)
class Target:
    """A CPU level the kernels are compiled for (LLVM's CPU name) and the CPU features
    (LLVM's names, as ``llvmlite.binding.get_host_cpu_features`` reports them) a
    machine needs to run that code."""

    cpu: str
    features: tuple[str, ...]


TARGETS = {
    "x86_64": Target(
        "x86-64-v2",
        # LLVM's x86-64-v2: the x86-64 baseline, then CX16, LAHF/SAHF, CRC32, POPCNT and
        # SSE4.2 with what it implies (SSE3, SSSE3, SSE4.1)
        (
            "cmov",
            "cx8",
            "fxsr",
            "mmx",
            "sse",
            "sse2",
            "cx16",
            "sahf",
            "crc32",
            "popcnt",
            "sse3",
            "ssse3",
            "sse4.1",
            "sse4.2",
        ),
    ),
}
"""The CPU level shipped kernels are compiled for, per machine architecture
(``platform.machine()``, lower case)."""

SHIPPED_PYTHONS = ("cpython-311", "cpython-313")
"""The Python versions (``sys.implementation.cache_tag``) whose zips are shipped, for
x86-64 Linux: those CI runs the tests with."""

_PACKAGE_ROOT = Path(__file__).resolve().parent


def enabled() -> bool:
    """Whether shipped kernels are installed: yes unless the environment sets
    ``NAO_ARENA_PRECOMPILED=0`` (then every kernel the cache lacks is compiled)."""
    return os.environ.get("NAO_ARENA_PRECOMPILED", "1").strip() != "0"


def _machine() -> str:
    return platform.machine().lower() or "unknown"


def target() -> Target | None:
    """The CPU level of this machine's architecture (None: none is shipped for it)."""
    return TARGETS.get(_machine())


def missing_features(features: Iterable[str]) -> list[str]:
    """The CPU ``features`` this machine lacks (LLVM's detection, which also asks the
    operating system whether it saves the registers)."""
    import llvmlite.binding as llvm

    have = llvm.get_host_cpu_features()
    return [f for f in features if not have.get(f, False)]


def bundle_tag() -> str:
    """The Python version, numba version and platform a zip is for, e.g.
    ``cpython-311-numba0.68.1-linux-x86_64``."""
    import numba

    return f"{sys.implementation.cache_tag}-numba{numba.__version__}-{sys.platform}-{_machine()}"


def bundle_path(folder: Path | None = None) -> Path:
    """The zip for this interpreter in ``folder`` (default: the shipped ones); it may
    not exist."""
    return (BUNDLE_FOLDER if folder is None else folder) / f"{bundle_tag()}.zip"


MAPPED_PACKAGES = ("nao_arena.agents", "nao_arena.maps_data")
"""The packages of folders outside ``nao_arena/`` in a checkout (pyproject.toml's
``package-dir``), inside it once installed."""


def _source_files() -> list[tuple[str, Path]]:
    """(name, path) of every Python module of the package, by a name that does not
    depend on where the package lies: a checkout, or site-packages, where the
    :data:`MAPPED_PACKAGES` are folders of the package."""
    from importlib.util import find_spec

    roots = [("nao_arena", _PACKAGE_ROOT)]
    for name in MAPPED_PACKAGES:
        spec = find_spec(name)
        if spec is None or not spec.submodule_search_locations:
            raise ImportError(f"no package {name}")
        roots.append((name, Path(list(spec.submodule_search_locations)[0]).resolve()))
    files: list[tuple[str, Path]] = []
    for prefix, root in roots:
        others = [r for _, r in roots if r != root and r.is_relative_to(root)]
        for path in root.rglob("*.py"):
            if "__pycache__" in path.parts or any(path.is_relative_to(o) for o in others):
                continue  # counted under its own package
            files.append((f"{prefix}/{path.relative_to(root).as_posix()}", path))
    return sorted(files)


@functools.cache
def source_digest() -> str:
    """SHA-256 of the package's modules (names and bytes): what a zip must have been
    built from to be used (read once per process)."""
    digest = hashlib.sha256()
    for name, path in _source_files():
        data = path.read_bytes()
        digest.update(f"{name}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()


@dataclass(frozen=True)
class Entry:
    """One cached kernel version in a zip: the kernel (``module.name``), its argument
    types (:func:`nao_arena.kernels.type_name` texts), numba's hashes of its bytecode
    and closure (part of numba's index key) and the zip member holding numba's data."""

    module: str
    name: str
    args: tuple[str, ...]
    code: tuple[str, str]
    data: str

    @property
    def key(self) -> str:
        """The manifest key of the kernel version."""
        from nao_arena.kernels import kernel_key

        return kernel_key(self.module, self.name, self.args)


@dataclass(frozen=True)
class BundleInfo:
    """What a zip's ``index.json`` says: its format, tag (:func:`bundle_tag`), the
    CPU level its code is for, source digest (:func:`source_digest`) and entries."""

    format: int
    tag: str
    target: Target
    digest: str
    entries: tuple[Entry, ...]


def read_info(archive: zipfile.ZipFile) -> BundleInfo:
    """The index of an open zip; ValueError if it is not one this module wrote."""
    try:
        raw = json.loads(archive.read(INDEX))
        entries = tuple(
            Entry(e["module"], e["name"], tuple(e["args"]), tuple(e["code"]), e["data"])
            for e in raw["entries"]
        )
        cpu = Target(str(raw["cpu"]), tuple(str(f) for f in raw["features"]))
        return BundleInfo(int(raw["format"]), str(raw["tag"]), cpu, str(raw["digest"]), entries)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"not a kernel bundle index ({exc})") from exc


# --------------------------------------------------------------------------- installing


@dataclass(frozen=True)
class InstallReport:
    """What :func:`install` did: entries written into the cache, entries the cache held
    already, and entries left (their kernel is gone or changed), with the reason no entry
    was written when the zip was not used (else empty)."""

    written: int = 0
    held: int = 0
    skipped: int = 0
    unused: str = ""


def install(keys: Iterable[str] | None = None, folder: Path | None = None) -> InstallReport:
    """Write the shipped entries of the kernel versions ``keys`` (manifest keys; default:
    every entry) that the cache lacks into numba's cache. Nothing when
    :func:`enabled` is false, no zip is shipped for this interpreter, or the zip was
    built from other sources; an unreadable zip or entry is left alone (logged at
    DEBUG): those kernels compile as they would without it."""
    if not enabled():
        return InstallReport(unused="NAO_ARENA_PRECOMPILED=0")
    path = bundle_path(folder)
    if not path.is_file():
        return InstallReport(unused=f"no {path.name} shipped")
    found = _fitting_info(path)
    if isinstance(found, str):
        return _unused(found)
    wanted = None if keys is None else set(keys)
    try:
        with zipfile.ZipFile(path) as archive:
            report = _install_entries(archive, found.entries, wanted)
    except (OSError, zipfile.BadZipFile) as exc:
        return _unused(f"{path.name} is unreadable ({exc})")
    if report.written:
        LOG.info("loaded %d precompiled kernels into the cache", report.written)
    return report


def install_kernel(module: str, name: str, args: Sequence[str]) -> bool:
    """Write the shipped entry of one kernel version (``module.name`` for the argument
    types ``args``, :func:`nao_arena.kernels.type_name` texts) into numba's cache when
    the cache lacks it and the shipped zip fits (checked once per process); whether it
    was written. The kernels' cache asks this on a miss
    (:class:`nao_arena.shared_code.KernelCache`), so that a kernel first called from
    Python (an :class:`~nao_arena.arena.Arena` in a notebook) is loaded, not compiled,
    as those of a run are."""
    if not enabled():
        return False
    shipped = _shipped_entries()
    if shipped is None:
        return False
    path, entries = shipped
    from nao_arena.kernels import kernel_key

    entry = entries.get(kernel_key(module, name, args))
    if entry is None:
        return False
    try:
        with zipfile.ZipFile(path) as archive:
            written = _install_entry(archive, entry) == "written"
    except Exception as exc:  # noqa: BLE001 - the kernel compiles instead
        LOG.debug("precompiled %s not installed (%r)", entry.key, exc)
        return False
    if written:
        LOG.debug("loaded the precompiled kernel %s into the cache", entry.key)
    return written


@functools.cache
def _shipped_entries() -> tuple[Path, dict[str, Entry]] | None:
    """The shipped zip for this process and its entries by manifest key, when it fits
    (:func:`_misfit`); None otherwise (once per process)."""
    path = bundle_path()
    found = _fitting_info(path)
    if isinstance(found, str):
        LOG.debug("precompiled kernels not used: %s", found)
        return None
    return path, {e.key: e for e in found.entries}


def _fitting_info(path: Path) -> BundleInfo | str:
    """The index of the zip at ``path`` when it can be used here; else why not."""
    try:
        with zipfile.ZipFile(path) as archive:
            info = read_info(archive)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        return f"{path.name} is unreadable ({exc})"
    return _misfit(path, info) or info


def _misfit(path: Path, info: BundleInfo) -> str:
    """Why the zip at ``path`` cannot be used here (empty: it can): another format or
    tag, a CPU without the features of its code, or other sources."""
    if info.format != FORMAT or info.tag != bundle_tag():
        return f"{path.name} is of format {info.format}, tag {info.tag}"
    if lacking := missing_features(info.target.features):
        return f"this CPU lacks {', '.join(lacking)} ({info.target.cpu})"
    if info.digest != source_digest():
        return f"{path.name} was built from other sources"
    return ""


def _unused(reason: str) -> InstallReport:
    LOG.debug("precompiled kernels not used: %s", reason)
    return InstallReport(unused=reason)


def _install_entries(
    archive: zipfile.ZipFile, entries: Sequence[Entry], wanted: set[str] | None
) -> InstallReport:
    written = held = skipped = 0
    for entry in entries:
        if wanted is not None and entry.key not in wanted:
            continue
        try:
            outcome = _install_entry(archive, entry)
        except Exception as exc:  # noqa: BLE001 - that kernel compiles when needed
            LOG.debug("precompiled %s not installed (%r)", entry.key, exc)
            outcome = "skipped"
        written += outcome == "written"
        held += outcome == "held"
        skipped += outcome == "skipped"
    return InstallReport(written, held, skipped)


def _install_entry(archive: zipfile.ZipFile, entry: Entry) -> str:
    """Write one entry into numba's cache: ``written``, ``held`` (the cache has it) or
    ``skipped`` (the kernel is gone, changed, or not cached by numba)."""
    dispatcher: Any = getattr(import_module(entry.module), entry.name, None)
    cache_file: Any = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    if cache_file is None:
        return "skipped"
    key = _index_key(dispatcher, entry.args)
    if tuple(key[2]) != entry.code:
        return "skipped"  # another bytecode: the source changed
    overloads = cache_file._load_index()
    if key in overloads:
        return "held"
    data = archive.read(entry.data)
    # named by its content, not numbered as numba's own: processes writing at once
    # (test workers, say) never write another entry's data under a name an index holds
    base = cache_file._index_name.removesuffix(".nbi")
    name = f"{base}.shipped-{hashlib.sha256(data).hexdigest()[:16]}.nbc"
    with cache_file._open_for_write(cache_file._data_path(name)) as out:
        out.write(data)
    overloads[key] = name
    cache_file._save_index(overloads)
    return "written"


def _index_key(dispatcher: Any, args: Sequence[str]) -> Any:
    """numba's index key of ``dispatcher``'s version for the argument types ``args``
    (:func:`nao_arena.kernels.type_name` texts) in this process: (signature, this
    codegen's CPU, hashes of the bytecode and closure)."""
    from nao_arena.kernels import parse_type

    signature = tuple(parse_type(a) for a in args)
    return dispatcher._cache._index_key(signature, dispatcher.targetctx.codegen())


# --------------------------------------------------------------------------- building


def build(out: Path, parts: Sequence[str] | None = None, jobs: int | None = None) -> Path:
    """Compile the kernels of ``parts`` (default: every recorded part) for this
    architecture's CPU level (:data:`TARGETS`) in a new, empty cache, in a Python
    process of its own, and pack them into ``out/<tag>.zip`` (written atomically).
    Returns its path."""
    import subprocess

    from nao_arena.kernels import RECORD_PARTS

    level = target()
    if level is None:
        raise RuntimeError(f"no CPU level is defined for {_machine()} (TARGETS)")
    parts = list(RECORD_PARTS if parts is None else parts)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="nao_arena_bundle_") as cache:
        env = dict(os.environ)
        env.update(
            NUMBA_CPU_NAME=level.cpu,
            NUMBA_CPU_FEATURES="",  # those of the CPU level alone
            NUMBA_CACHE_DIR=cache,
            NAO_ARENA_PRECOMPILED="0",
            NAO_ARENA_COMPILE_AHEAD="1",
        )
        command = [sys.executable, "-m", "nao_arena.precompiled", "_pack", str(out)]
        command += [*parts, *(["--jobs", str(jobs)] if jobs else [])]
        subprocess.run(command, env=env, check=True)
    return bundle_path(out)


def _pack(out: Path, parts: Sequence[str], jobs: int | None) -> Path:
    """In the process :func:`build` starts: compile ``parts`` ahead, then write the zip."""
    from numba.core import config

    from nao_arena.atomic import atomic_write_with
    from nao_arena.kernels import compile_ahead, load_manifest

    level, numba_config = target(), cast(Any, config)
    if level is None or (numba_config.CPU_NAME, numba_config.CPU_FEATURES) != (level.cpu, ""):
        raise RuntimeError("the kernels are packed only when compiled for the CPU level")
    report = compile_ahead(parts, jobs)
    if report.failed:
        raise RuntimeError(f"{len(report.failed)} kernels failed to compile: {report.summary()}")
    kernels = load_manifest().for_parts(parts)
    entries, members = _entries(kernels.values())
    info = {
        "format": FORMAT,
        "tag": bundle_tag(),
        "cpu": level.cpu,
        "features": list(level.features),
        "digest": source_digest(),
        "entries": [
            {
                "module": e.module,
                "name": e.name,
                "args": list(e.args),
                "code": list(e.code),
                "data": e.data,
            }
            for e in entries
        ],
    }
    path = bundle_path(out)

    def write(name: str) -> None:
        with zipfile.ZipFile(name, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as archive:
            files = {INDEX: json.dumps(info, indent=0, sort_keys=True).encode(), **members}
            for member, data in sorted(files.items()):
                # a fixed date: the bytes depend on the members alone
                entry = zipfile.ZipInfo(member, date_time=(1980, 1, 1, 0, 0, 0))
                archive.writestr(entry, data, zipfile.ZIP_DEFLATED, compresslevel=9)

    atomic_write_with(path, write, suffix=".zip")
    LOG.info("wrote %s: %d entries", path, len(entries))
    return path


def _entries(kernels: Iterable[Any]) -> tuple[list[Entry], Mapping[str, bytes]]:
    """The cache entries of ``kernels`` (manifest :class:`~nao_arena.kernels.Kernel`),
    with the data of each under its member name."""
    entries: list[Entry] = []
    members: dict[str, bytes] = {}
    for kernel in sorted(kernels, key=lambda k: k.key):
        dispatcher = getattr(import_module(kernel.module), kernel.name)
        cache = dispatcher._cache
        key = _index_key(dispatcher, kernel.args)
        name = cache._cache_file._load_index().get(key)
        if name is None:
            raise RuntimeError(f"{kernel.key} is not in the cache after compiling")
        member = f"data/{len(members):04d}.nbc"
        members[member] = Path(cache._cache_file._data_path(name)).read_bytes()
        code = (str(key[2][0]), str(key[2][1]))
        entries.append(Entry(kernel.module, kernel.name, tuple(kernel.args), code, member))
    return entries, members


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m nao_arena.precompiled build [FOLDER [PART ...]] [--jobs N]``: write
    this interpreter's zip into FOLDER (default: the shipped folder), of every part or
    of the PARTs."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m nao_arena.precompiled")
    parser.add_argument("command", choices=["build", "_pack"])
    parser.add_argument("out", nargs="?", default=str(BUNDLE_FOLDER))
    parser.add_argument("parts", nargs="*")
    parser.add_argument("--jobs", type=int, default=None)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    parts = args.parts or None
    if args.command == "_pack":
        from nao_arena.kernels import RECORD_PARTS

        _pack(Path(args.out), list(parts or RECORD_PARTS), args.jobs)
    else:
        print(build(Path(args.out), parts, args.jobs))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
