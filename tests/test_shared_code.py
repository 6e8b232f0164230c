"""Shared callees (nao_arena.shared_code): a large kernel is called, not copied, by its
callers, and a caller loaded from the cache in a new process finds it there.

Each probe runs in a process of its own on a module of kernels written for the test
(its cache beside it): one process compiles, the next ones load from the cache.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np

from nao_arena import shared_code
from nao_arena.jit import kernel

# 60 lines of distinct arithmetic: well over SHARED_INSTRUCTIONS LLVM instructions
_BIG_BODY = "\n".join(
    f"    y = math.sin(y + {k / 7:.6f}) * 1.0001 + math.cos(y * 0.3 + {k})" for k in range(60)
)
BIG = f"""
import math

from nao_arena.jit import inner_kernel


@inner_kernel
def big(x):
    y = x
{_BIG_BODY}
    return y + OFFSET


OFFSET = {{offset}}
"""

KERNELS = """
from nao_arena.jit import inner_kernel, kernel

from sharing_big import big


@inner_kernel
def small(x):
    return big(x) + 1.0


@kernel
def first(x):
    return small(x) * 2.0


@kernel
def caller(x):
    return small(x) - big(x) + big(x)
"""

PROBE = """
import json, sys
from numba.core import event
from nao_arena.shared_code import shared_callees
compiled = []
class Watch(event.Listener):
    def on_start(self, ev): compiled.append(ev.data["dispatcher"].py_func.__name__)
    def on_end(self, ev): pass
event.register("numba:compile", Watch())
import sharing_kernels as k
import sharing_big
k.big = sharing_big.big
value = getattr(k, sys.argv[1])(0.5)
libs = {f.py_func.__name__: [o.library for o in f.overloads.values()] for f in
        (k.big, k.small, k.first, k.caller)}
names = {id(lib): name for name, ls in libs.items() for lib in ls}
shares = {name: sorted(names.get(id(s), "?") for lib in ls for s in shared_callees(lib))
          for name, ls in libs.items()}
print(json.dumps({"value": value, "compiled": compiled, "shares": shares,
                  "loaded": {name: len(ls) for name, ls in libs.items()}}))
"""


def _probe(folder, entry: str) -> dict:
    import json

    out = subprocess.run(
        [sys.executable, "-c", PROBE, entry], cwd=folder, capture_output=True, text=True
    )
    assert out.returncode == 0, f"probe {entry} failed ({out.returncode}): {out.stderr[-2000:]}"
    return json.loads(out.stdout)


def _reference(x: float) -> float:
    y = x
    for k in range(60):
        y = math.sin(y + float(f"{k / 7:.6f}")) * 1.0001 + math.cos(y * 0.3 + k)
    return y


def _write(folder, offset: float) -> None:
    (folder / "sharing_big.py").write_text(BIG.format(offset=offset))
    (folder / "sharing_kernels.py").write_text(KERNELS)


def test_a_large_callee_is_shared_and_found_by_callers_loaded_from_the_cache(tmp_path):
    _write(tmp_path, 0.0)
    big = _reference(0.5)
    # 1: compiles first, small and big; small calls big where it is, not a copy of it
    one = _probe(tmp_path, "first")
    assert one["compiled"] == ["first", "small", "big"]
    assert math.isclose(one["value"], 2.0 * (big + 1.0), rel_tol=1e-12)
    assert one["shares"]["small"] == ["big"]
    assert one["shares"]["first"] == []  # small is small: linked (its call to big inside)
    # 2: small and big come from the cache; caller compiles, calling big directly and
    # through the copy of small it links
    two = _probe(tmp_path, "caller")
    assert two["compiled"] == ["caller"]
    assert math.isclose(two["value"], big + 1.0, rel_tol=1e-12)
    assert two["shares"]["caller"] == ["big"]
    # 3: caller from the cache: big is loaded before it (its reload functions: its own
    # share, and small's, restored from small's cache entry in process 2)
    three = _probe(tmp_path, "caller")
    assert three["compiled"] == []
    assert three["loaded"] == {"big": 1, "small": 0, "first": 0, "caller": 1}
    assert three["value"] == two["value"]
    # 4: first from the cache (its small copy calls big): big is loaded first
    four = _probe(tmp_path, "first")
    assert four["compiled"] == [] and four["value"] == one["value"]
    assert four["loaded"]["big"] == 1


@kernel
def _sum_of(values):
    total = 0.0
    for v in values:
        total += v
    return total


def test_the_package_s_kernels_are_tagged_and_numbas_own_code_is_not():
    _sum_of(np.arange(3.0))
    (cres,) = _sum_of.overloads.values()
    load = cres.library._nao_arena_callee
    assert load == shared_code.LoadCallee(
        __name__,
        "_sum_of",
        ("Array(float64, 1, 'C', False, aligned=True)",),
        cres.fndesc.mangled_name,
    )
    from numba import njit

    plain = njit(lambda x: x + 1)
    plain(1)
    (other,) = plain.overloads.values()
    assert not hasattr(other.library, "_nao_arena_callee")


def test_a_kernel_that_is_not_a_module_attribute_is_always_linked():
    # a later process could not find it to load it before its callers
    @kernel
    def _twice(x):
        return 2.0 * x

    assert _twice(1.5) == 3.0
    (cres,) = _twice.overloads.values()
    assert not hasattr(cres.library, "_nao_arena_callee")


def test_a_cached_caller_of_a_changed_callee_is_compiled_again(tmp_path):
    # a linked copy of the old callee would stay in the cached caller; a shared callee
    # whose source changed is not in the cache, so the caller is a cache miss
    _write(tmp_path, 0.0)
    before = _probe(tmp_path, "caller")
    assert before["compiled"] == ["caller", "small", "big"]
    assert _probe(tmp_path, "caller")["compiled"] == []
    (tmp_path / "sharing_big.py").write_text(BIG.format(offset=10.0) + "\n# changed\n")
    after = _probe(tmp_path, "caller")
    assert "caller" in after["compiled"] and "big" in after["compiled"]
    assert math.isclose(after["value"], before["value"] + 10.0, rel_tol=1e-12)
    again = _probe(tmp_path, "caller")
    assert again["compiled"] == [] and again["value"] == after["value"]
