"""The compiled kernels' bookkeeping (nao_arena.kernels): the compile clock, the
wall-clock budget that leaves compiles out, the manifest, compiling ahead of time."""

from __future__ import annotations

import json
import logging
import math
import os
import re
import subprocess
import sys
import textwrap
import time

import numba
import pytest

import nao_arena.kernels as kernels
from nao_arena.agent import BUILTIN_AGENTS
from nao_arena.kernels import (
    CORE,
    RECORD_PARTS,
    CompileReport,
    Kernel,
    Manifest,
    compile_ahead,
    compile_count,
    compile_seconds,
    kernel_key,
    load_manifest,
    manifest_from_json,
    manifest_to_json,
    map_part,
    missing_kernels,
    parts_for_agents,
    type_name,
    watch_compiles,
)
from nao_arena.watchdog import EpisodeTimeout, budget_available, wall_clock_budget


def _slow_to_compile(n: int = 300):
    """A new compiled function each call, whose compile takes a while (n branches)."""
    lines = ["def kernel(x):", "    y = 0.0"]
    for i in range(n):
        lines += [f"    if x > {i}.5:", f"        y += math.sqrt(x * {i}.0 + 1.0) / (y + 1.0)"]
    lines.append("    return y")
    scope = {"math": math}
    exec("\n".join(lines), scope)
    return numba.njit(cache=False)(scope["kernel"])


def test_the_clock_counts_compiles():
    watch_compiles()
    before, count = compile_seconds(), compile_count()
    numba.njit(lambda x: x * 3)(2)
    assert compile_count() == count + 1
    assert compile_seconds() > before


@pytest.mark.skipif(not budget_available(), reason="needs SIGALRM on the main thread")
def test_a_compile_does_not_count_against_the_budget():
    """A block whose compile alone takes twice its budget finishes; its other time still
    counts (so the test can fail both ways)."""
    watch_compiles()
    before = compile_seconds()
    _slow_to_compile()(1.0)
    budget = (compile_seconds() - before) / 2  # half a compile of the same size, s
    with wall_clock_budget(budget):
        time.sleep(0.1 * budget)
        _slow_to_compile()(1.0)
        time.sleep(0.1 * budget)
    with pytest.raises(EpisodeTimeout), wall_clock_budget(budget):
        _slow_to_compile()(1.0)
        time.sleep(1.5 * budget)
    with pytest.raises(EpisodeTimeout), wall_clock_budget(budget):
        time.sleep(1.5 * budget)


def test_the_shipped_manifest_names_real_kernels_and_types():
    manifest = load_manifest()
    assert manifest.numba and len(manifest.kernels) > 50
    from nao_arena.kernels import _dispatcher, parse_type

    for key, kernel in manifest.kernels.items():
        assert key == kernel.key
        assert isinstance(_dispatcher(kernel), numba.core.dispatcher.Dispatcher), key
        for text in kernel.args:
            assert type_name(parse_type(text)) == text
        assert set(kernel.calls) <= set(manifest.kernels), key
        assert kernel.parts and set(kernel.parts) <= set(RECORD_PARTS), key
    nao = manifest.for_parts(["nao"])
    core = manifest.for_parts([CORE])
    assert set(core) <= set(manifest.for_parts(parts_for_agents(["nao"])))
    assert not set(nao) <= set(core) and not set(core) <= set(nao)


def test_named_tuples_and_int_enums_have_names_that_read_back():
    """A kernel taking a named tuple (the stopping plans' Knowledge) or an IntEnum (the
    NAO outcome) can be in the manifest, and so compiled ahead like any other: its
    argument types are named with their classes' modules and read back exactly."""
    from numba import typeof

    from nao_arena.geometry.outcome import Outcome
    from nao_arena.kernels import _nameable, parse_type
    from nao_arena.stopping import no_knowledge

    for value in (no_knowledge(), Outcome.DESIRED):
        numba_type = typeof(value)
        text = type_name(numba_type)
        assert parse_type(text) == numba_type and _nameable([text])
        assert ":" in text  # the class's module is named
    keys = load_manifest().kernels
    assert any(k.startswith("nao_arena.stopping:commit_plans_kernel(") for k in keys)
    assert any("named_tuple(" in k for k in keys)


def test_an_inner_kernel_is_called_by_kernels_and_from_python_through_a_twin(tmp_path):
    """An inner kernel has no Python wrapper: a compiled caller calls it (cached), and a
    call from Python goes to its twin (same results) instead of crashing."""
    module = tmp_path / "inner_probe.py"
    module.write_text(
        textwrap.dedent("""
            import numpy as np
            from nao_arena.jit import inner_kernel, kernel

            @inner_kernel(error_model="numpy")
            def scaled(x, out):
                out[0] = 2.0 * x
                return x + 1.0

            @kernel
            def caller(x):
                out = np.zeros(1)
                return scaled(x, out) + out[0]
        """)
    )
    probe = textwrap.dedent("""
        import json, numpy as np, inner_probe
        from nao_arena.jit import twins_made
        first = inner_probe.caller(1.5)
        before = twins_made()
        out = np.zeros(1)
        direct = inner_probe.scaled(1.5, out)
        print(json.dumps([first, before, direct, float(out[0]), twins_made()]))
    """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(tmp_path)}
    runs = []
    for _ in range(2):  # the second loads the caller from the cache
        out = subprocess.run(
            [sys.executable, "-c", probe], cwd=tmp_path, env=env, capture_output=True, text=True
        )
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(json.loads(out.stdout))
    for first, before, direct, written, after in runs:
        assert first == 2.5 + 3.0 and before == []
        assert direct == 2.5 and written == 3.0 and after == ["inner_probe.scaled"]


def test_manifest_json_round_trip():
    k = Kernel("m", "f", ("int64",), ("m:g(int64)",), ("core",), 1.5)
    g = Kernel("m", "g", ("int64",), (), ("core",), 0.25)
    manifest = Manifest("0.0", {k.key: k, g.key: g})
    assert manifest_from_json(manifest_to_json(manifest)) == manifest
    assert json.loads(manifest_to_json(manifest))["kernels"][k.key]["calls"] == [g.key]
    assert kernel_key("m", "f", ["int64", "bool"]) == "m:f(int64, bool)"
    assert set(manifest.for_parts(["core"])) == {k.key, g.key}
    assert manifest.for_parts(["nao"]) == {}


def test_a_map_part_keeps_only_what_the_maps_episodes_call():
    """map:NAME narrows the agent parts to the kernels NAME's recorded episodes call, with
    their callees; an unknown map narrows nothing."""
    callee = Kernel("m", "c", ("int64",), (), ("nao",), 1.0, ("busy",))
    a = Kernel("m", "a", ("int64",), (callee.key,), ("nao",), 1.0, ("quiet",))
    b = Kernel("m", "b", ("int64",), (), ("nao",), 1.0, ("busy",))
    core = Kernel("m", "k", ("int64",), (), ("core",), 1.0, ("busy", "quiet"))
    orca = Kernel("m", "o", ("int64",), (), ("orca",), 1.0, ("quiet",))
    manifest = Manifest("0.0", {k.key: k for k in (callee, a, b, core, orca)})
    assert manifest_from_json(manifest_to_json(manifest)) == manifest
    quiet = manifest.for_parts([CORE, "nao", map_part("quiet")])
    assert set(quiet) == {a.key, callee.key, core.key}  # a's callee comes along
    assert set(manifest.for_parts([CORE, "nao", map_part("busy")])) == {
        b.key,
        callee.key,
        core.key,
    }
    everything = manifest.for_parts([CORE, "nao"])
    assert manifest.for_parts([CORE, "nao", map_part("mine.yaml")]) == everything
    # the shipped manifest: every shipped map recorded; roundabout needs less than all
    from nao_arena.maps import available_maps

    shipped = load_manifest()
    recorded = {m for k in shipped.kernels.values() for m in k.maps}
    assert recorded == set(available_maps())
    nao = shipped.for_parts(parts_for_agents(["nao"]))
    roundabout = shipped.for_parts([*parts_for_agents(["nao"]), map_part("roundabout")])
    assert set(roundabout) < set(nao)


def test_parts_for_agents():
    assert parts_for_agents(["nao", "nao", "x.py:Mine", "orca"]) == ["core", "nao", "orca"]
    assert set(BUILTIN_AGENTS) <= set(RECORD_PARTS)


def test_compile_ahead_fills_the_cache_callees_first(tmp_path, monkeypatch, caplog):
    """Kernels compiled ahead in worker processes are in the cache; a fresh process then
    loads them without compiling; the callee is compiled before its caller. The progress
    and the summary are logged."""
    (tmp_path / "ahead_kernels.py").write_text(
        textwrap.dedent("""
        from numba import njit

        @njit(cache=True)
        def inner(x):
            return 2.0 * x

        @njit(cache=True)
        def outer(x):
            return inner(x) + 1.0
    """)
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    inner = Kernel("ahead_kernels", "inner", ("float64",), (), ("core",), 0.1)
    outer = Kernel("ahead_kernels", "outer", ("float64",), (inner.key,), ("core",), 0.1)
    manifest = Manifest(numba.__version__, {inner.key: inner, outer.key: outer})
    assert missing_kernels(["core"], manifest) == [outer.key]  # only what no kernel calls
    order = []
    monkeypatch.setattr(kernels, "PROGRESS_INTERVAL", 0.0)  # every kernel's progress
    with caplog.at_level(logging.INFO, logger="nao_arena.kernels"):
        report = compile_ahead(
            ["core"],
            jobs=2,
            manifest=manifest,
            on_done=lambda done, total, key: order.append((done, total, key)),
        )
    assert report.kernels == 2 and not report.failed and report.jobs == 2
    assert order == [(1, 2, inner.key), (2, 2, outer.key)]
    logged = [r.getMessage() for r in caplog.records]
    assert logged[0] == "compiling 2 kernels in 2 processes ..."
    assert logged[1].startswith("compiled 1/2 kernels in ")
    assert logged[1].endswith(" s (last: ahead_kernels:inner)")
    assert logged[2] == report.summary(" (cached for later runs)") and len(logged) == 3
    assert missing_kernels(["core"], manifest) == []
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="nao_arena.kernels"):
        again = compile_ahead(iter(["core"]), jobs=2, manifest=manifest)
    # every kernel cached: they are checked, and the summary says none compiled
    assert again.kernels == 2 and not again.failed
    logged = [r.getMessage() for r in caplog.records]
    assert logged[0] == "checking the 2 cached kernels in 2 processes ..."
    probe = textwrap.dedent("""
        import sys
        from numba.core import event
        compiled = []
        class L(event.Listener):
            def on_start(self, ev): compiled.append(ev.data["dispatcher"].py_func.__name__)
            def on_end(self, ev): pass
        event.register("numba:compile", L())
        import ahead_kernels
        assert ahead_kernels.outer(1.5) == 4.0 and ahead_kernels.inner(1.0) == 2.0
        print(compiled)
    """)
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]"


def test_a_compile_ahead_without_processes_says_so(monkeypatch, caplog):
    """Where no process can start, every kernel is left to compile when called, and the
    summary logged says so with the reason."""

    def no_pool(*args, **kwargs):
        raise OSError("no processes here")

    monkeypatch.setattr(kernels, "ProcessPoolExecutor", no_pool)
    k = Kernel("m", "f", ("float64",), (), ("core",), 0.1)
    with caplog.at_level(logging.INFO, logger="nao_arena.kernels"):
        report = compile_ahead(["core"], jobs=2, manifest=Manifest("", {k.key: k}))
    assert report.compiled == 0 and list(report.failed) == [k.key]
    assert [r.getMessage() for r in caplog.records][-1] == (
        "0 of 1 kernels compiled or loaded in 0 s (0 s of CPU) with 0 processes; "
        "1 left to compile when called (first error: no processes here)"
    )


def test_a_stale_manifest_entry_is_reported_not_raised(tmp_path, monkeypatch):
    (tmp_path / "stale_kernels.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x + 1\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    gone = Kernel("stale_kernels", "g", ("float64",), (), ("core",), 0.1)
    fine = Kernel("stale_kernels", "f", ("float64",), (), ("core",), 0.1)
    report = compile_ahead(
        ["core"], jobs=1, manifest=Manifest("", {gone.key: gone, fine.key: fine})
    )
    assert list(report.failed) == [gone.key] and report.kernels == 2
    # nor does looking for what the cache lacks: the gone entry has nothing to compile
    assert missing_kernels(["core"], Manifest("", {gone.key: gone})) == []


def test_a_compile_error_is_reported_without_terminal_colours(tmp_path, monkeypatch):
    """With colorama installed numba styles its typing errors with terminal escapes (and
    pays for it on every overload that does not match); the compile workers turn that
    off, so a failed kernel's reason reads as plain text."""
    pytest.importorskip("colorama")
    (tmp_path / "typo_kernels.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef h(x):\n    return x + 'a'\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    bad = Kernel("typo_kernels", "h", ("float64",), (), ("core",), 0.1)
    report = compile_ahead(["core"], jobs=1, manifest=Manifest("", {bad.key: bad}))
    reason = report.failed[bad.key]
    assert reason.startswith("TypingError") and "\x1b[" not in reason


def test_a_worker_settles_each_kernels_garbage(tmp_path):
    """After each kernel a compile worker has collected that compile's garbage and frozen
    what is left, whether the kernel compiled or failed (in a process of its own, as a
    worker is: freezing is process-wide)."""
    (tmp_path / "settle_kernels.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return 2.0 * x\n"
    )
    probe = textwrap.dedent("""
        import gc
        from nao_arena import kernels

        for name in ("f", "gone"):
            gc.unfreeze()
            seconds, error = kernels._compile_one("settle_kernels", name, ("float64",))
            assert (error is None) == (name == "f"), error
            assert gc.get_freeze_count() > 1000 and gc.get_count()[2] == 0
        print("settled")
    """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True, env=env
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "settled"


def test_the_workers_quick_flags_answer_as_numba_does():
    """The compile workers' faster flag comparisons (``_quick_flags``) give numba's own
    values, hashes and equalities: 400 pairs of random flags, with options set to other
    values, set to their defaults (equal to unset ones) or left unset. In a process of
    its own: the change is to numba's class."""
    probe = textwrap.dedent("""
        import random
        from numba.core.compiler import Flags
        from nao_arena import kernels

        rng = random.Random(0)
        bools = [k for k, o in Flags.options.items() if o.type is bool]

        def flags():
            f = Flags()
            for name in rng.sample(bools, rng.randint(0, 4)):
                setattr(f, name, rng.random() < 0.5)  # the default, or not
            if rng.random() < 0.5:
                f.error_model = rng.choice(["python", "numpy"])
            return f

        pairs = [(flags(), flags()) for _ in range(400)]
        pairs += [(a, Flags(a)) for a, _ in pairs[:50]]
        before = [(a.values(), b.values(), hash(a), hash(b), a == b, a != b) for a, b in pairs]
        kernels._quick_flags()
        after = [(a.values(), b.values(), hash(a), hash(b), a == b, a != b) for a, b in pairs]
        assert after == before
        assert [list(a.values()) for a, _ in pairs] == [list(v) for v, *_ in before]
        assert Flags.values.__module__ == "nao_arena.kernels"  # the patch is in place
        print(sum(eq for *_, eq, _ in before), "equal pairs")
    """)
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    equal = int(out.stdout.split()[0])
    assert 50 <= equal < 450  # both outcomes were compared
    # a numba whose flags answer otherwise (here: a hash of the values) keeps its own
    other = textwrap.dedent("""
        from numba.core import targetconfig
        from numba.core.compiler import Flags
        from nao_arena import kernels

        def other_hash(self):
            return hash(repr(self.values()))

        targetconfig.TargetConfig.__hash__ = other_hash
        kernels._quick_flags()
        assert targetconfig.TargetConfig.__hash__ is other_hash
        assert Flags.values.__module__ != "nao_arena.kernels"
    """)
    out = subprocess.run([sys.executable, "-c", other], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


@pytest.mark.slow
@pytest.mark.installed
def test_the_manifest_lists_every_kernel_of_the_shipped_maps(tmp_path):
    """Each built-in agent on every shipped map (and a few frames of a GIF) uses only
    kernels that the manifest lists (else: python -m nao_arena.kernels record), but for
    those whose argument types cannot be named (function pointers: compiled when called)."""
    probe = textwrap.dedent("""
        import json, os, sys, tempfile
        from nao_arena.agent import BUILTIN_AGENTS
        from nao_arena.arena import Arena, ArenaOptions
        from nao_arena.kernels import _loaded_kernels, _nameable, type_name
        from nao_arena.maps import available_maps
        from nao_arena.render import record_episode
        for name in available_maps():
            for agent in BUILTIN_AGENTS:
                Arena(load_map(name), ArenaOptions(agent=agent)).run(0, max_steps=3)
        arena = Arena(load_map("crossing"), ArenaOptions(agent="goal"))
        arena.reset(0)
        record_episode(arena, os.path.join(sys.argv[1], "x.gif"), max_steps=2)
        from nao_arena.jit import twins_made
        print(json.dumps(twins_made()))
        print(json.dumps(sorted(key for key, (_, sig, _) in _loaded_kernels().items()
                                if _nameable(type_name(t) for t in sig))))
    """).replace(
        "from nao_arena.maps import available_maps",
        "from nao_arena.maps import available_maps, load_map",
    )
    # run from tmp_path: `python -c` imports from its working folder first
    out = subprocess.run(
        [sys.executable, "-c", probe, str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    used = set(json.loads(out.stdout.splitlines()[-1]))
    # no production path calls a kernel compiled for compiled callers only from Python
    assert json.loads(out.stdout.splitlines()[-2]) == []
    missing = used - set(load_manifest().kernels)
    assert not missing, f"not in the manifest (python -m nao_arena.kernels record): {missing}"


def test_an_env_compiles_ahead_once_per_map_and_never_in_a_daemonic_process(monkeypatch):
    import multiprocessing

    import nao_arena.kernels as kernels

    asked: list[list[str]] = []
    monkeypatch.setattr(kernels, "missing_kernels", lambda parts: ["some"])
    monkeypatch.setattr(kernels, "_compile_in_subprocess", lambda parts: asked.append(parts))
    monkeypatch.setattr(kernels, "_ENV_ENSURED", set())
    monkeypatch.delenv("NAO_ARENA_COMPILE_AHEAD", raising=False)
    kernels.ensure_env_compiled("circle_swap")
    kernels.ensure_env_compiled("circle_swap")
    kernels.ensure_env_compiled("my_maps/x.yaml")
    assert asked == [[CORE, "env", map_part("circle_swap")], [CORE, "env"]]

    class Daemon:
        daemon = True

    real_process = multiprocessing.current_process
    monkeypatch.setattr(multiprocessing, "current_process", lambda: Daemon())
    kernels.ensure_env_compiled("crossing")  # e.g. a SubprocVecEnv worker
    assert len(asked) == 2
    monkeypatch.setattr(multiprocessing, "current_process", real_process)
    monkeypatch.setenv("NAO_ARENA_COMPILE_AHEAD", "0")
    kernels.ensure_env_compiled("corridor")  # turned off
    monkeypatch.delenv("NAO_ARENA_COMPILE_AHEAD")
    monkeypatch.setattr(kernels, "missing_kernels", lambda parts: [])
    kernels.ensure_env_compiled("intersection")  # nothing missing
    assert len(asked) == 2

    def fails(parts):
        raise OSError("no processes here")

    monkeypatch.setattr(kernels, "missing_kernels", lambda parts: ["some"])
    monkeypatch.setattr(kernels, "_compile_in_subprocess", fails)
    kernels.ensure_env_compiled("doorway")  # a failure leaves the kernels to compile later


@pytest.mark.slow
@pytest.mark.installed
def test_a_new_env_compiles_its_first_steps_kernels_ahead(tmp_path):
    """With an empty cache, a script that makes an env (with no ``__main__`` guard) has
    what its first steps call compiled ahead in other processes, which do not run the
    script again: its reset and first step compile next to nothing in its process. The
    compile's messages reach the script's logging."""
    (tmp_path / "script.py").write_text(
        textwrap.dedent("""
            import json, logging
            logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
            import nao_arena, nao_arena.kernels as kernels
            print("script runs", flush=True)
            env = nao_arena.parallel_env("circle_swap")
            ahead = kernels.compile_count()
            left = kernels.missing_kernels(["core", "env", "map:circle_swap"])
            env.reset(seed=0)
            for i, agent in enumerate(env.agents):
                env.action_space(agent).seed(i)
            env.step({a: env.action_space(a).sample() for a in env.agents})
            print(json.dumps([ahead, left, kernels.compile_count()]))
        """)
    )
    # the kernels compile, not loaded from the shipped ones (tests/test_precompiled.py)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NAO_ARENA_PRECOMPILED": "0"}
    env.pop("NAO_ARENA_COMPILE_AHEAD", None)
    out = subprocess.run(
        [sys.executable, "script.py"], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.strip().splitlines()
    assert lines[0] == "script runs" and len(lines) == 2  # the script ran once
    ahead, left, after = json.loads(lines[1])
    assert ahead == 0 and left == [] and after <= 2, (ahead, left, after)
    logged = [line for line in out.stderr.splitlines() if line.startswith("nao_arena.kernels")]
    assert logged[:2] == [
        "nao_arena.kernels: compiling the kernels of an env of circle_swap ahead ...",
        f"nao_arena.kernels: compiling {ahead_total(logged)} kernels in "
        f"{os.cpu_count()} processes ...",
    ]
    summary = re.compile(
        r"nao_arena\.kernels: (\d+) of \1 kernels compiled or loaded in \d+ s "
        r"\(\d+ s of CPU\) with \d+ process(es)? \(cached for later runs\)$"
    )
    assert summary.match(logged[-1]), logged


def ahead_total(logged: list[str]) -> str:
    """The count of kernels in the compile-ahead summary among ``logged``."""
    return logged[-1].split(": ", 1)[1].split(" of ")[0]


def test_the_compile_summary_counts_only_the_kernels_that_compiled() -> None:
    """A compile in which kernels failed (as every one does on a numba the package does
    not support) says how many of them are cached, and the first error."""
    failed = {"m:f(int64)": "AttributeError: no _reload_init\nmore", "m:g(int64)": "Other"}
    line = CompileReport(3, failed, 2, 4.2, 7.9).summary(" (cached)")
    assert line == (
        "1 of 3 kernels compiled or loaded in 4 s (8 s of CPU) with 2 processes (cached); "
        "2 left to compile when called (first error: AttributeError: no _reload_init)"
    )
    assert CompileReport(2, {}, 1, 0.4).summary() == (
        "2 of 2 kernels compiled or loaded in 0 s (0 s of CPU) with 1 process"
    )
