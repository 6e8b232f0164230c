"""The versioned envs of :mod:`nao_arena.envs`: one module per shipped map, PettingZoo's
conventions (``env``, ``parallel_env``, ``metadata["name"]``), the listing, and a guard
that tells when a change calls for a new version."""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import pickle
import pkgutil
import re
import warnings
from importlib.resources import files
from pathlib import Path

import numpy as np
import pettingzoo
import pytest
import yaml
from pettingzoo.test import api_test, parallel_api_test

import nao_arena.envs
from nao_arena.environment import parallel_env as map_env
from nao_arena.envs import available, load
from nao_arena.maps import available_maps

CHEAP = {
    "circle_swap": {"n": 3},
    "circle_swap_perturbed": {"n": 3},
    "crowd": {"n": 3},
    "corridor": {"n": 1},
    "crossing": {"n": 1},
    "doorway": {"n": 1},
    "doorway_perturbed": {"n": 1},
    "intersection": {"n": 1},
    "intersection_perturbed": {"n": 1},
    "warehouse_aisles": {"n": 1},
    "warehouse_aisles_perturbed": {"n": 1},
    "pillar_corridor": {"n": 1},
    "pillar_corridor_perturbed": {"n": 1},
}
"""Map parameters that keep the API tests quick."""


def cheap(name: str) -> dict:
    return {"map_params": CHEAP.get(load(name).MAP, {}), "time_limit": 1.5}


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        # PettingZoo's advice on agent names and infinite observation bounds
        warnings.simplefilter("ignore", UserWarning)
        yield


def test_available_lists_the_modules_present():
    present = sorted(
        m.name for m in pkgutil.iter_modules(nao_arena.envs.__path__) if not m.name.startswith("_")
    )
    assert available() == present
    assert all(re.fullmatch(r"[a-z_]+_v\d+", n) for n in present)


def test_every_shipped_map_has_a_versioned_env():
    maps = {load(n).MAP: n for n in available()}
    assert sorted(maps) == available_maps()
    for map_name, name in maps.items():
        assert name.rsplit("_v", 1)[0] == map_name


@pytest.mark.parametrize("name", available())
def test_versioned_env_follows_pettingzoo_conventions(name):
    module = importlib.import_module(f"nao_arena.envs.{name}")
    assert module is load(name)
    assert set(module.__all__) == {"MAP", "env", "parallel_env"}
    par = module.parallel_env(**cheap(name))
    assert isinstance(par, pettingzoo.ParallelEnv)
    assert par.metadata["name"] == name
    parallel_api_test(par, num_cycles=20)
    aec = module.env(**cheap(name))
    assert isinstance(aec, pettingzoo.AECEnv) and aec.metadata["name"] == name


def test_aec_form_passes_the_api_test():
    from nao_arena.envs import circle_swap_v0

    api_test(circle_swap_v0.env(n=3, time_limit=1.5), num_cycles=20)


def test_versioned_env_is_its_map_with_the_default_options():
    from nao_arena.envs import crossing_v0

    def run(e) -> list:
        obs, _ = e.reset(seed=4)
        out = [obs]
        rng = np.random.default_rng(0)
        for _ in range(8):
            out.append(e.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in e.agents}))
        return out

    a, b = run(crossing_v0.parallel_env(n=2)), run(map_env("crossing", n=2))
    assert pickle.dumps(a) == pickle.dumps(b)
    assert map_env("crossing").metadata["name"] == "nao_arena_v0"  # unchanged


def test_versioned_env_keeps_its_name_through_copies():
    from nao_arena.envs import corridor_v0

    twin = pickle.loads(pickle.dumps(corridor_v0.parallel_env(n=1)))
    assert twin.metadata["name"] == "corridor_v0"
    assert pickle.loads(pickle.dumps(corridor_v0.parallel_env)) is corridor_v0.parallel_env


def test_the_map_is_fixed_and_unknown_names_are_refused():
    from nao_arena.envs import roundabout_v0

    with pytest.raises(
        TypeError,
        match=r"roundabout_v0.parallel_env: the map is fixed "
        r"\('roundabout'\), got map='crossing'",
    ):
        roundabout_v0.parallel_env(map="crossing")
    with pytest.raises(TypeError, match="the map is fixed"):
        roundabout_v0.env(map="crossing")
    with pytest.raises(
        ValueError,
        match=r"unknown env 'roundabout_v9': expected one of "
        r"circle_swap_perturbed_v0, .*two_lane_road_v0",
    ):
        load("roundabout_v9")


@pytest.mark.skipif(
    not hasattr(pettingzoo, "register"),
    reason="PettingZoo's registry (pettingzoo.make) came in 1.27",
)
def test_versioned_envs_are_in_pettingzoos_registry():
    for name in available():
        assert f"nao_arena/{name.replace('_v', '-v')}" in pettingzoo.parallel_registry
        assert f"nao_arena/{name.replace('_v', '-v')}" in pettingzoo.aec_registry
    par = pettingzoo.make("parallel", "nao_arena/two_lane_road_v0", time_limit=1.0)
    assert par.metadata["name"] == "two_lane_road_v0"
    aec = pettingzoo.make("aec", "nao_arena/crossing", n=1)  # the newest version
    assert aec.metadata["name"] == "crossing_v0"


# ---------------------------------------------------------------- the version guard

FINGERPRINTS = {
    "circle_swap_perturbed_v0": "c25073190e5ae244",
    "circle_swap_v0": "e9f0487eba31b841",
    "corridor_v0": "f9c1909908676ab6",
    "crossing_streams_perturbed_v1": "e0c981feb5538235",
    "crossing_streams_v1": "7524ebd79b0b0f58",
    "crossing_v0": "9f39f5b480cfcc0d",
    "crowd_v0": "b159d9e9b845b71e",
    "crowdnav_circle_v0": "4937803cf2a9fd9c",
    "crowdnav_square_v0": "88cd722538e1fa21",
    "dense_swap_perturbed_v1": "ff22e16eaca86e5d",
    "dense_swap_v1": "45e129dddd20b5b5",
    "doorway_perturbed_v0": "59d52da2e272f1d9",
    "doorway_v0": "2caaf68d89d0f394",
    "intersection_perturbed_v0": "934bacd6ef696d64",
    "intersection_v0": "7a37408de608a455",
    "pillar_corridor_perturbed_v0": "69b65069aa81cb1f",
    "pillar_corridor_v0": "deb84a3f4865926f",
    "roundabout_crossing_v0": "5139c52a73cbc5eb",
    "roundabout_v0": "6b032afce64d8cff",
    "two_lane_road_v0": "a56e01cebd4a8e4a",
    "warehouse_aisles_perturbed_v0": "0c945849c8c4558d",
    "warehouse_aisles_v0": "fe330a55d8d2250d",
}
"""Digest of what of each env affects learning and hashes the same on every platform: the
map file, the default options, the agents, the observation and action spaces. Dynamics
(physics, agents, traffic, map builders) are not in it: a change there calls for a new
version too (see :mod:`nao_arena.envs`)."""


def _without_description(data: dict) -> dict:
    """A map file's data less its ``description`` (prose for people, not the scene)."""
    return {k: v for k, v in data.items() if k != "description"}


def fingerprint(name: str) -> str:
    module = load(name)
    par = module.parallel_env()
    obs, act = (
        par.observation_space(par.possible_agents[0]),
        par.action_space(par.possible_agents[0]),
    )
    options = dataclasses.asdict(par.options)
    for cosmetic in ("render_size", "selected"):
        del options[cosmetic]
    del options["arena"]["stats"]  # thresholds of the statistics, not of the rewards
    # settings added after these versions, left out at the value that changes nothing
    for section, key, neutral in (
        (options, "trust_map", False),
        (options, "named_agents", {}),
        (options, "agent_names", "map"),
        (options["arena"], "max_faults", None),
        (options["arena"], "sensing_latency", None),
        (options["arena"], "actuation_noise", None),
        (options["arena"], "sensing_noise", None),
        (options["arena"], "sensing_dropout", None),
        (options["arena"], "sensing_field_of_view", None),
        (options["arena"], "sensing_occlusion", None),
        (options["arena"], "actuation_lag", None),
        (options["arena"], "communication_range", None),
        (options["arena"], "communication_latency", None),
        (options["arena"], "communication_loss", None),
    ):
        if section[key] == neutral:
            del section[key]
    data = {
        "map": _without_description(
            yaml.safe_load((files("nao_arena.maps_data") / f"{module.MAP}.yaml").read_text())
        ),
        "options": options,
        "agents": par.possible_agents,
        "observation": [obs.shape, obs.low.tobytes().hex(), obs.high.tobytes().hex()],
        "action": [act.shape, act.low.tobytes().hex(), act.high.tobytes().hex()],
    }
    text = json.dumps(data, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@pytest.mark.parametrize("name", available())
def test_what_affects_learning_is_unchanged_within_a_version(name):
    assert fingerprint(name) == FINGERPRINTS.get(name), (
        f"{name}: the map file, the default options, the agents or the spaces changed; "
        f"that changes what is learned: rename the module to the next version "
        f"({_next(name)}, also in nao_arena.envs._NAMES) and record its fingerprint here"
    )


def _next(name: str) -> str:
    base, version = name.rsplit("_v", 1)
    return f"{base}_v{int(version) + 1}"


def test_readme_lists_every_versioned_env():
    page = Path(__file__).resolve().parents[1] / "docs" / "how-to" / "rl.md"
    section = page.read_text(encoding="utf-8").split("\n## Training with RL\n", 1)[1]
    listed = re.search(r"^`circle_swap_v0`.*?\n\n", section, re.M | re.S).group(0)
    assert sorted(re.findall(r"`(\w+_v\d+)`", listed)) == available()
