"""The precompiled kernels shipped with the package (:mod:`nao_arena.precompiled`): built
from these sources, loaded into an empty cache instead of compiled, and left alone when
they do not fit."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from nao_arena import precompiled
from nao_arena.kernels import load_manifest


def shipped() -> list[Path]:
    return sorted(precompiled.BUNDLE_FOLDER.glob("*.zip"))


def test_the_python_versions_ci_runs_on_have_their_kernels_shipped():
    """On x86-64 Linux, each Python version of :data:`SHIPPED_PYTHONS` (those CI runs
    the tests with) has a zip for the numba installed here."""
    names = {p.name for p in shipped()}
    assert names, "no precompiled kernels shipped: python -m nao_arena.precompiled build"
    if (sys.platform, platform.machine()) != ("linux", "x86_64"):
        pytest.skip("kernels are shipped for x86-64 Linux only")
    if sys.implementation.cache_tag not in precompiled.SHIPPED_PYTHONS:
        pytest.skip(f"no kernels are shipped for {sys.implementation.cache_tag}")
    assert precompiled.bundle_path().name in names


@pytest.mark.parametrize("path", shipped(), ids=lambda p: p.stem)
def test_a_shipped_zip_was_built_from_these_sources_and_holds_every_kernel(path):
    """Else: ``python -m nao_arena.precompiled build`` with that zip's Python (after
    every change of the package's modules)."""
    with zipfile.ZipFile(path) as archive:
        info = precompiled.read_info(archive)
        members = set(archive.namelist())
    assert (info.format, info.tag) == (precompiled.FORMAT, path.stem)
    assert info.target == precompiled.TARGETS[info.tag.rsplit("-", 1)[1]]
    assert info.tag.split("-numba")[0] in precompiled.SHIPPED_PYTHONS
    assert info.digest == precompiled.source_digest(), f"{path.name} is stale: rebuild it"
    assert sorted(e.key for e in info.entries) == sorted(load_manifest().kernels)
    assert {e.data for e in info.entries} <= members
    assert len({e.data for e in info.entries}) == len(info.entries)


def test_the_source_digest_covers_every_module_and_nothing_else():
    names = [name for name, _ in precompiled._source_files()]
    assert "nao_arena/kernels.py" in names and "nao_arena/geometry/_kernel/exact.py" in names
    assert "nao_arena.agents/nao.py" in names and "nao_arena.agents/_nao_batch.py" in names
    assert all(n.endswith(".py") and "__pycache__" not in n for n in names)
    assert len(names) == len(set(names))
    assert "nao_arena.maps_data/__init__.py" in names
    assert not any(n.startswith(("nao_arena/agents/", "nao_arena/maps_data/")) for n in names)


def test_the_mapped_packages_are_those_of_pyproject():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    pyproject = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    mapped = set(pyproject["tool"]["setuptools"]["package-dir"]) - {"nao_arena"}
    assert mapped == set(precompiled.MAPPED_PACKAGES)


def write_zip(folder: Path, info: dict, members: dict[str, bytes] | None = None) -> Path:
    path = precompiled.bundle_path(folder)
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr(precompiled.INDEX, json.dumps(info))
        for name, data in (members or {}).items():
            archive.writestr(name, data)
    return path


def index(**changes) -> dict:
    info = {
        "format": precompiled.FORMAT,
        "tag": precompiled.bundle_tag(),
        "cpu": "x86-64-v2",
        "features": ["sse2"],
        "digest": precompiled.source_digest(),
        "entries": [],
    }
    return {**info, **changes}


def test_a_zip_that_does_not_fit_is_not_used(tmp_path, monkeypatch):
    """Other sources, another tag or format, a CPU without the code's features, an
    unreadable zip, no zip, or the switch off: nothing is written, and the report says
    why."""
    monkeypatch.delenv("NAO_ARENA_PRECOMPILED", raising=False)
    cases = {
        "this CPU lacks no-such-feature (x86-64-v2)": index(features=["no-such-feature"]),
        "built from other sources": index(digest="0" * 64),
        "tag cpython-0": index(tag="cpython-0"),
        "format 99": index(format=99),
        "unreadable": {"entries": "no"},
    }
    for reason, info in cases.items():
        folder = tmp_path / reason.replace(" ", "_")
        folder.mkdir()
        write_zip(folder, info)
        report = precompiled.install(folder=folder)
        assert report.written == 0 and reason in report.unused, (reason, report)
    garbage = tmp_path / "garbage"
    garbage.mkdir()
    precompiled.bundle_path(garbage).write_bytes(b"not a zip")
    assert "unreadable" in precompiled.install(folder=garbage).unused
    assert "no cpython" in precompiled.install(folder=tmp_path / "none").unused
    monkeypatch.setenv("NAO_ARENA_PRECOMPILED", "0")
    assert precompiled.install(folder=garbage).unused == "NAO_ARENA_PRECOMPILED=0"


def test_this_machine_has_the_features_of_its_cpu_level():
    """LLVM reports the host's features by the names the levels use: an x86-64 CI
    machine has those of x86-64-v2 (else no test would use the shipped kernels), and a
    feature no CPU has is reported missing."""
    assert precompiled.missing_features(["no-such-feature"]) == ["no-such-feature"]
    level = precompiled.target()
    if level is None:
        pytest.skip(f"no CPU level for {platform.machine()}")
    assert precompiled.missing_features(level.features) == []


def test_an_entry_of_a_changed_or_missing_kernel_is_skipped(tmp_path, monkeypatch):
    """An entry whose kernel's bytecode is not what it was compiled from, or whose
    kernel is gone, is skipped (that kernel compiles when needed); only the entries
    asked for are looked at."""
    monkeypatch.delenv("NAO_ARENA_PRECOMPILED", raising=False)
    kernel = next(iter(load_manifest().kernels.values()))
    entries = [
        {
            "module": kernel.module,
            "name": kernel.name,
            "args": list(kernel.args),
            "code": ["0" * 64, "0" * 64],
            "data": "data/0.nbc",
        },
        {
            "module": kernel.module,
            "name": "gone_kernel",
            "args": list(kernel.args),
            "code": ["0" * 64, "0" * 64],
            "data": "data/1.nbc",
        },
        {
            "module": "nao_arena.no_such_module",
            "name": "f",
            "args": ["float64"],
            "code": ["0" * 64, "0" * 64],
            "data": "data/2.nbc",
        },
    ]
    members = {f"data/{i}.nbc": b"never read" for i in range(3)}
    write_zip(tmp_path, index(entries=entries), members)
    report = precompiled.install(folder=tmp_path)
    assert (report.written, report.held, report.skipped, report.unused) == (0, 0, 3, "")
    only = precompiled.install([kernel.key], folder=tmp_path)
    assert (only.written, only.skipped) == (0, 1)


@pytest.mark.slow
@pytest.mark.installed
def test_a_first_run_loads_the_shipped_kernels_and_compiles_none(tmp_path):
    """In an empty cache, an arena made in Python (no compile ahead: each kernel is
    looked up in the shipped ones when the cache misses it) and the README's command
    (which writes those it needs first, one line on stderr) compile none, and the
    episode is the one this process runs (the golden trajectories check the shipped
    code's bits against those recorded with code compiled on the machine); so is a
    first env."""
    if not precompiled.bundle_path().is_file():
        pytest.skip(f"no kernels shipped for {precompiled.bundle_tag()}")
    probe = (
        "import json, logging\n"
        "from nao_arena import kernels\n"
        "from nao_arena.arena import Arena, ArenaOptions\n"
        "from nao_arena.maps import load_map\n"
        "logging.basicConfig(level=logging.DEBUG)\n"
        "kernels.watch_compiles()\n"
        "arena = Arena(load_map('roundabout'), ArenaOptions(agent='nao'))\n"
        "arena.run(0, max_steps=60)\n"
        "print(json.dumps([kernels.compile_count(), arena.summary().trajectory_hash]))\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NAO_ARENA_PRECOMPILED", None)
    env.pop("NAO_ARENA_COMPILE_AHEAD", None)
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr[-2000:]
    compiled, trajectory = json.loads(out.stdout.splitlines()[-1])
    assert compiled == 0
    assert "loaded the precompiled kernel nao_arena." in out.stderr
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    here = Arena(load_map("roundabout"), ArenaOptions(agent="nao"))
    here.run(0, max_steps=60)
    assert trajectory == here.summary().trajectory_hash
    cli = Path(sys.executable).with_name("nao-arena")
    run = subprocess.run(
        [str(cli), "run", "roundabout"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**env, "NUMBA_CACHE_DIR": str(tmp_path / "cli_cache")},
    )
    assert run.returncode == 0, run.stderr[-2000:]
    loaded = len(load_manifest().for_parts(["core", "nao", "map:roundabout"]))
    line = f"nao-arena: loaded {loaded} precompiled kernels into the cache"
    assert run.stderr.splitlines() == [line]
    # each entry's data under a name of its content: processes writing at once never
    # put one entry's data under another's name
    data = [p.name for p in (tmp_path / "cli_cache").rglob("*.nbc")]
    assert len(data) == loaded and all(".shipped-" in name for name in data)
    env_probe = (
        "import logging, nao_arena\n"
        "from nao_arena import kernels\n"
        "logging.basicConfig(level=logging.INFO)\n"
        "kernels.watch_compiles()\n"
        "env = nao_arena.parallel_env('circle_swap')\n"
        "env.reset(seed=0)\n"
        "env.step({a: env.action_space(a).sample() for a in env.agents})\n"
        "print(kernels.compile_count())\n"
    )
    first_env = subprocess.run(
        [sys.executable, "-c", env_probe],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**env, "NUMBA_CACHE_DIR": str(tmp_path / "env_cache")},
    )
    assert first_env.returncode == 0, first_env.stderr[-2000:]
    assert int(first_env.stdout.split()[-1]) <= 2  # as with the kernels compiled ahead
    assert "loaded" in first_env.stderr and "compiling" not in first_env.stderr


def test_nao_arena_compile_loads_the_shipped_kernels_before_compiling(monkeypatch):
    """``nao-arena compile`` (which looks at every kernel) writes the shipped kernels
    the cache lacks first, then compiles ahead what is left; with
    ``NAO_ARENA_COMPILE_AHEAD=0`` it loads none."""
    import nao_arena.kernels as kernels
    from nao_arena._cli_compile import compile_parts

    calls: list[tuple[str, list[str]]] = []
    monkeypatch.setattr(kernels, "load_shipped", lambda parts: calls.append(("load", parts)))
    monkeypatch.setattr(
        kernels, "compile_ahead", lambda parts, jobs=None: calls.append(("compile", parts))
    )
    monkeypatch.delenv("NAO_ARENA_COMPILE_AHEAD", raising=False)
    compile_parts(["core", "goal"], force=True)
    assert calls == [("load", ["core", "goal"]), ("compile", ["core", "goal"])]
    calls.clear()
    monkeypatch.setenv("NAO_ARENA_COMPILE_AHEAD", "0")
    compile_parts(["core"], force=True)
    assert calls == [("compile", ["core"])]
