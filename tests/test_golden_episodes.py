"""Golden episodes: refactors keep every trajectory bit for bit.

A fixed set of short episodes (every shipped map with the ``nao`` agent, the
baselines and predictors on the paper's maps and the swap, the env's NAO
features and the NAO shield) is run and each episode's trajectory hash (or a
SHA-256 of the env's observations and rewards) is compared with the values
recorded in ``tests/data/golden_episodes.json``.

Floating-point results may differ between library versions and platforms, so
the file holds one record per platform and library set (operating system,
architecture, and the minor versions of Python, numpy, numba and pymunk, which
pyproject.toml pins to what is recorded). The CPU model is not part of it: the
records of an Intel Xeon and an AMD EPYC were the same, hash for hash. A library
set without a record of its own passes where it reproduces the hash of another
record of the same platform (Python 3.12 and numba 0.64 gave every hash of the
Python 3.11, numba 0.68 record). Otherwise, on x86-64 Linux, the platform CI
lands on, it fails these tests loudly (they never skip there); elsewhere it skips
with the reason. To record this machine's hashes (after an intended change of
behaviour, re-record on every platform or drop the others' records)::

    python tests/test_golden_episodes.py --record
"""

from __future__ import annotations

import hashlib
import json
import platform
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

try:  # tests/ as a rootdir-relative package or as a plain directory on sys.path
    from tests.pins import newest_admitted
except ImportError:  # pragma: no cover
    from pins import newest_admitted

DATA = Path(__file__).parent / "data" / "golden_episodes.json"

# (map, agent, predictor or None for the map's, control steps)
ARENA_CASES: list[tuple[str, str, str | None, int]] = [
    ("circle_swap", "nao", None, 150),
    ("circle_swap", "nao", "constant_velocity", 100),
    ("circle_swap", "nao", "constant_acceleration", 100),
    ("circle_swap", "nao", "shared_plan", 100),
    ("circle_swap_perturbed", "nao", None, 150),
    ("circle_swap", "ao", None, 100),
    ("circle_swap", "vo", None, 100),
    ("circle_swap", "orca", None, 100),
    ("circle_swap", "goal", None, 100),
    ("corridor", "nao", None, 120),
    ("crossing", "nao", None, 150),
    ("crossing_streams", "nao", None, 120),
    ("crossing_streams_perturbed", "nao", None, 120),
    ("crowd", "nao", None, 120),
    ("dense_swap", "nao", None, 60),
    ("doorway", "nao", None, 100),
    ("doorway_perturbed", "nao", None, 100),
    ("intersection", "nao", None, 100),
    ("pillar_corridor", "nao", None, 100),
    ("warehouse_aisles", "nao", None, 100),
    ("dense_swap_perturbed", "nao", None, 60),
    ("roundabout", "nao", None, 120),
    ("roundabout", "nao", "turn_rate", 80),
    ("roundabout", "ao", None, 80),
    ("roundabout", "vo", None, 80),
    ("roundabout", "orca", None, 80),
    ("roundabout", "goal", None, 80),
    ("roundabout_crossing", "nao", None, 60),
    ("two_lane_road", "nao", None, 60),
    ("two_lane_road", "ao", None, 40),
]


def _minor(version: str) -> str:
    """``"2.4.6"`` -> ``"2.4"``."""
    return ".".join(version.split(".")[:2])


def machine() -> dict[str, str]:
    """What floating-point results depend on: platform and the libraries' minor versions."""
    import numba
    import pymunk

    return {
        "system": platform.system(),
        "machine": platform.machine(),
        "python": _minor(platform.python_version()),
        "numpy": _minor(np.__version__),
        "numba": _minor(numba.__version__),
        "pymunk": _minor(pymunk.version),
    }


def must_run(here: dict[str, str]) -> bool:
    """Whether the golden episodes must run here (x86-64 Linux, where CI runs)."""
    return here["system"] == "Linux" and here["machine"] in ("x86_64", "AMD64")


def arena_hash(map_name: str, agent: str, predictor: str | None, steps: int) -> str:
    """Trajectory hash of ``steps`` control steps of the map (seed 0)."""
    from nao_arena.arena import Arena, ArenaOptions
    from nao_arena.maps import load_map

    overrides = {"agent": agent}
    if predictor is not None:
        overrides["predictor"] = predictor
    arena = Arena(load_map(map_name, **overrides), ArenaOptions())
    arena.reset(seed=0)
    for _ in range(steps):
        arena.step()
    return arena.summary().trajectory_hash


def _env_digest(env, steps: int, seed: int) -> str:
    out = hashlib.sha256()
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        for name in sorted(obs):
            out.update(np.ascontiguousarray(obs[name], dtype=np.float64).tobytes())
        if not env.agents:
            break
        actions = {
            a: env.action_space(a).sample() * 0
            + rng.uniform(-2, 2, 2).astype(env.action_space(a).dtype)
            for a in env.agents
        }
        obs, rewards, _, _, infos = env.step(actions)
        for name in sorted(rewards):
            out.update(np.float64(rewards[name]).tobytes())
        for name in sorted(infos):
            shield = infos[name].get("shield")
            if shield is not None:
                out.update(repr(sorted(shield.items())).encode())
    return out.hexdigest()


def env_features_hash() -> str:
    """Observations (NAO features on) and rewards of 60 random-action steps on crossing."""
    from nao_arena.environment import parallel_env

    return _env_digest(parallel_env("crossing", nao_features=True, keep_finished=True), 60, 3)


def shield_hash() -> str:
    """Observations, rewards and shield reports of 60 random-action steps on circle_swap."""
    from nao_arena.environment import parallel_env
    from nao_arena.shield import NAOShield

    return _env_digest(NAOShield(parallel_env("circle_swap", keep_finished=True)), 60, 5)


def cases() -> dict[str, Callable[[], str]]:
    """Every golden case by name."""
    out: dict[str, Callable[[], str]] = {}
    for map_name, agent, predictor, steps in ARENA_CASES:
        key = f"{map_name}/{agent}/{predictor or 'map'}/{steps}"
        out[key] = lambda m=map_name, a=agent, p=predictor, s=steps: arena_hash(m, a, p, s)
    out["env/crossing/nao_features/60"] = env_features_hash
    out["shield/circle_swap/60"] = shield_hash
    return out


def _records() -> list[dict]:
    """The data file's records: {"machine": ..., "hashes": {case: hash}} each."""
    if not DATA.exists():
        return []
    return json.loads(DATA.read_text())["records"]


def unmatched(name: str, value: str, here: dict[str, str], records: list[dict]) -> str | None:
    """Why the hash ``value`` of case ``name`` on the library set ``here`` is wrong, or
    None when it is right: equal to the record of ``here``; without such a record, equal
    to that of any other library set of the same platform (a Python, numpy, numba or
    pymunk version without a record that reproduces the trajectories bit for bit)."""
    exact = [r["hashes"] for r in records if r["machine"] == here]
    if exact:
        if name not in exact[0]:
            return f"{name} not recorded (python {__file__} --record)"
        return None if value == exact[0][name] else f"{name}: trajectory changed"
    platform_of = ("system", "machine")
    alike = [
        r
        for r in records
        if all(r["machine"][k] == here[k] for k in platform_of) and name in r["hashes"]
    ]
    if any(r["hashes"][name] == value for r in alike):
        return None
    return (
        f"{name}: golden hashes recorded for {[r['machine'] for r in records]}, this is "
        f"{here}, and the trajectory differs from every record of this platform: install "
        f"the versions pyproject.toml pins, or record this library set (python {__file__} "
        f"--record) after checking that nothing else changed"
    )


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(cases()))
def test_golden_episode(name: str) -> None:
    here = machine()
    why = unmatched(name, cases()[name](), here, _records())
    if why is None:
        return
    if must_run(here) or any(r["machine"] == here for r in _records()):
        pytest.fail(why)
    pytest.skip(why)


def test_an_unrecorded_library_set_passes_only_with_a_recorded_trajectory() -> None:
    """The judge of a golden hash: its own record decides; without one, any record of the
    same platform that it reproduces."""
    linux = {"system": "Linux", "machine": "x86_64"}
    py311 = {**linux, "python": "3.11", "numpy": "2.4", "numba": "0.68", "pymunk": "7.3"}
    py312 = {**py311, "python": "3.12"}
    mac = {**py311, "system": "Darwin", "machine": "arm64"}
    records = [{"machine": py311, "hashes": {"a": "1", "b": "2"}}]
    assert unmatched("a", "1", py311, records) is None
    assert unmatched("a", "9", py311, records) == "a: trajectory changed"
    assert "not recorded" in str(unmatched("c", "1", py311, records))
    assert unmatched("a", "1", py312, records) is None
    assert "differs from every record" in str(unmatched("a", "9", py312, records))
    assert "differs from every record" in str(unmatched("a", "1", mac, records))
    both = [*records, {"machine": py312, "hashes": {"a": "7"}}]
    assert unmatched("a", "7", py312, both) is None
    assert unmatched("a", "1", py312, both) == "a: trajectory changed"


def test_the_pins_admit_the_recorded_library_set() -> None:
    """pyproject.toml caps numpy, numba and pymunk just above a recorded minor version, so
    a fresh install (CI's) lands on a library set the golden records hold."""
    caps = newest_admitted()
    assert sorted(caps) == ["numba", "numpy", "pymunk"]
    recorded = [r["machine"] for r in _records()]
    for lib, minor in caps.items():
        assert minor in {m[lib] for m in recorded}, (lib, recorded)


def record() -> None:
    """Run every case and write this machine's record into the data file (atomically;
    the other machines' records are kept)."""
    hashes = {name: fn() for name, fn in sorted(cases().items())}
    here = machine()
    records = [r for r in _records() if r["machine"] != here]
    records.append({"machine": here, "hashes": hashes})
    DATA.parent.mkdir(exist_ok=True)
    tmp = DATA.with_suffix(".tmp")
    tmp.write_text(json.dumps({"records": records}, indent=1) + "\n")
    tmp.replace(DATA)
    print(f"recorded {len(hashes)} golden episodes of {here} in {DATA}")


if __name__ == "__main__":
    if sys.argv[1:] == ["--record"]:
        record()
    else:
        sys.exit(f"usage: python {sys.argv[0]} --record")
