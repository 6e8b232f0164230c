"""A trial's settings and its grid of episodes: :class:`TrialConfig`, one
:class:`EpisodeTask` per map x agent x episode, agent labels, per-episode seeds and maps,
and where each episode's files go (see :mod:`nao_arena.trials`)."""

from __future__ import annotations

import math
import re
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nao_arena.agent import available_agents
from nao_arena.backends import BACKENDS
from nao_arena.maps import MapError, MapSpec, load_map, with_time_limit

__all__ = [
    "FREE_SETTINGS",
    "LOG_MODES",
    "EpisodeTask",
    "TrialConfig",
    "TrialResult",
    "episode_path",
    "episode_seed",
    "grid_tasks",
    "log_path",
    "make_map",
    "map_overrides",
    "split_agent",
]


FREE_SETTINGS = frozenset(
    {"workers", "backend", "address", "csv", "retry_failed", "episode_timeout", "log", "trust_map"}
)
"""Settings that do not change results: they may differ from the ``trial.json`` of the
output folder (``episodes`` may also grow)."""

LOG_MODES = ("all", "contacts")
"""What ``TrialConfig.log`` may be: log every episode, or those with a contact or a
stuck robot."""


@dataclass(frozen=True)
class TrialConfig:
    """A trial: the grid ``maps`` x ``agents`` x ``episodes`` and how to run it.

    maps: shipped map names or map file paths; agents: the agents' names in
    the grid (what the files, tables and plots show): agent references
    (built-in names, ``FILE.py:Class``, ``module:Class``, plug-in names) or
    labels; agent_refs: label -> agent reference for the agents named by a
    label (``--agent mine=path/to/mine.py:Mine``; see :func:`split_agent`);
    seed: the trial's root seed; workers: local processes (1 = in this
    process), or the CPUs of the local Ray instance; out: the results
    folder; overrides: map parameters (``name -> value``), each applied to
    the maps of the grid that declare it; time_limit: episode time limit
    (s) replacing the maps' own (None: keep them); csv: also write CSV
    files; retry_failed: run again the episodes whose recorded result is an
    error; backend: ``local`` or ``ray`` (see :mod:`nao_arena.backends`);
    address: the Ray cluster to connect to (None: a local Ray instance;
    only with ``backend="ray"``); episode_timeout: each episode's
    wall-clock budget (s; None or 0: none), an episode that exceeds it is
    recorded as failed (``EpisodeTimeout: ...``) and the trial goes on (see
    :mod:`nao_arena.watchdog` for where it is enforced); log: write episode logs
    (:data:`LOG_MODES`; None: none; see :mod:`nao_arena.trials`); max_faults: an
    episode whose agents fault more often fails (``TooManyFaults: ...``; None: never);
    trust_map: the maps may name code as their robots' agents (``--trust-map``; see
    :func:`nao_arena.maps.load_map`; the agents' labels are names they may use).
    """

    maps: tuple[str, ...]
    agents: tuple[str, ...]
    episodes: int = 10
    seed: int = 0
    workers: int = 1
    out: Path = Path("results")
    overrides: Mapping[str, Any] = field(default_factory=dict)
    time_limit: float | None = None
    csv: bool = False
    retry_failed: bool = False
    backend: str = "local"
    address: str | None = None
    episode_timeout: float | None = 600.0
    agent_refs: Mapping[str, str] = field(default_factory=dict)
    log: str | None = None
    max_faults: int | None = None
    trust_map: bool = False

    def __post_init__(self) -> None:
        if not self.maps:
            raise ValueError("a trial needs at least one map")
        if not self.agents:
            raise ValueError("a trial needs at least one agent")
        for kind, names in (("map", self.maps), ("agent", self.agents)):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"{kind} listed twice: {', '.join(dup)}")
        if self.episodes < 1:
            raise ValueError(f"episodes: expected >= 1, got {self.episodes}")
        if self.seed < 0:
            raise ValueError(f"seed: expected >= 0, got {self.seed}")
        if self.workers < 1:
            raise ValueError(f"workers: expected >= 1, got {self.workers}")
        if self.backend not in BACKENDS:
            raise ValueError(f"unknown backend {self.backend!r}; choose from {', '.join(BACKENDS)}")
        if self.address is not None and self.backend != "ray":
            raise ValueError("an address is for the ray backend (--backend ray)")
        if self.time_limit is not None and not 0 < self.time_limit < math.inf:
            raise ValueError(f"time limit: expected a finite time > 0 s, got {self.time_limit}")
        if self.episode_timeout is not None and not 0 <= self.episode_timeout < math.inf:
            raise ValueError(
                f"episode timeout: expected a number of s >= 0 (0: none), "
                f"got {self.episode_timeout}"
            )
        if self.max_faults is not None and (
            isinstance(self.max_faults, bool)
            or not isinstance(self.max_faults, int)
            or self.max_faults < 0
        ):
            raise ValueError(f"max faults: expected an integer >= 0, got {self.max_faults!r}")
        if self.log is not None and self.log not in LOG_MODES:
            raise ValueError(
                f"log: expected one of {', '.join(LOG_MODES)} (or none), got {self.log!r}"
            )
        if "seed" in self.overrides:
            raise ValueError(
                "the map parameter 'seed' is set per episode by the trial; "
                "choose the trial's root seed instead (--seed)"
            )
        for label, ref in self.agent_refs.items():
            if label not in self.agents:
                raise ValueError(
                    f"agent label {label!r} is not one of the agents {', '.join(self.agents)}"
                )
            _check_label(label, ref)

    def reference(self, agent: str) -> str:
        """The agent reference to load for ``agent`` (a label or a reference itself)."""
        return self.agent_refs.get(agent, agent)


@dataclass(frozen=True)
class EpisodeTask:
    """One episode of a trial, as sent to a worker.

    agent: the agent's name in the grid; seed: the episode's integer seed;
    overrides: the map parameters for this map (without ``seed``); path: its
    result file; episode_timeout: its wall-clock budget (s; None or 0: none;
    not part of its key); agent_ref: the agent reference to load (None:
    ``agent`` itself; not part of its key, ``trial.json`` records it); log: which
    episodes write a log (:data:`LOG_MODES`; None: none) and log_path: where (neither
    is part of its key); max_faults: see :class:`TrialConfig` (part of its key when set);
    trust_map and named_agents: what the map may name (see :func:`make_map`).
    """

    map: str
    agent: str
    episode: int
    seed: int
    overrides: Mapping[str, Any]
    time_limit: float | None
    path: str
    episode_timeout: float | None = None
    agent_ref: str | None = None
    log: str | None = None
    log_path: str | None = None
    max_faults: int | None = None
    trust_map: bool = False
    named_agents: Mapping[str, str] = field(default_factory=dict)

    def key(self) -> dict[str, Any]:
        """What identifies the episode's result (compared on resume)."""
        key = {
            "map": self.map,
            "agent": self.agent,
            "episode": self.episode,
            "seed": self.seed,
            "overrides": dict(self.overrides),
            "time_limit": self.time_limit,
        }
        if self.max_faults is not None:
            key["max_faults"] = self.max_faults
        return key


@dataclass
class TrialResult:
    """What :func:`run_trial` did: the summary rows, episodes run now and skipped
    (already done), and the files written."""

    summary: list[dict[str, Any]]
    ran: int
    skipped: int
    files: list[Path]


# --------------------------------------------------------------------------- agent labels


def split_agent(text: str) -> tuple[str, str]:
    """``"NAME=REFERENCE"`` -> (label, reference); any other text is its own label.

    A label names the agent in tables, plots and results files (e.g.
    ``mine=path/to/mine.py:Mine``); text whose part before the first ``=``
    holds ``/``, ``\\`` or ``:`` is a reference. ValueError for an empty
    label or reference, or a label that names another known agent.
    """
    label, sep, ref = text.partition("=")
    label, ref = label.strip(), ref.strip()
    if not sep or any(c in label for c in "/:\\"):
        return text.strip(), text.strip()
    if not label or not ref:
        raise ValueError(f"agent {text!r}: expected NAME=REFERENCE, e.g. mine=path/to/mine.py:Mine")
    _check_label(label, ref)
    return label, ref


def _check_label(label: str, ref: str) -> None:
    """ValueError unless ``label`` is a plain name that names no other known agent."""
    if not label or any(c in label for c in "/:\\,=") or label != label.strip():
        raise ValueError(
            f"agent label {label!r}: expected a short name without "
            "'/', ':', ',', '=' or surrounding spaces, e.g. mine"
        )
    known = available_agents()
    if label in known and label != ref:
        raise ValueError(
            f"agent label {label!r} is the name of the agent {known[label]}: "
            f"choose another label for {ref}"
        )


# --------------------------------------------------------------------------- seeds and maps


def episode_seed(seed: int, map_name: str, episode: int) -> int:
    """The integer seed in [0, 2^32) of episode ``episode`` of map ``map_name`` in a trial
    with root seed ``seed``: a child of ``SeedSequence(seed)`` with spawn key
    ``(crc32(map_name), episode)``."""
    root = np.random.SeedSequence(seed)
    key = (zlib.crc32(map_name.encode("utf-8")), int(episode))
    child = np.random.SeedSequence(root.entropy, spawn_key=root.spawn_key + key)
    return int(child.generate_state(1, dtype=np.uint32)[0])


def map_overrides(maps: Sequence[str], overrides: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Per map, the overrides among ``overrides`` that it declares as parameters.

    Raises :class:`~nao_arena.maps.MapError` for an unknown map, and for an
    override that no map of the list declares (naming the declared ones).
    """
    declared = {m: set(load_map(m).parameters) for m in maps}
    for key in overrides:
        if not any(key in names for names in declared.values()):
            listing = "; ".join(
                f"{m}: {', '.join(sorted(names)) or 'none'}" for m, names in declared.items()
            )
            raise MapError(f"parameter override {key!r}: no map declares it (declared: {listing})")
    return {m: {k: v for k, v in overrides.items() if k in declared[m]} for m in maps}


def make_map(
    name: str,
    seed: int | None,
    overrides: Mapping[str, Any] | None = None,
    time_limit: float | None = None,
    *,
    trusted: bool = False,
    agents: Mapping[str, str] | None = None,
) -> MapSpec:
    """Load map ``name`` with ``overrides``; ``seed`` becomes its ``seed`` parameter if it
    declares one; ``time_limit`` (s) replaces its episode time limit if given; ``trusted``
    and ``agents``: what its robots may name (see :func:`nao_arena.maps.load_map`)."""
    params = dict(overrides or {})
    if (
        seed is not None
        and "seed" in load_map(name, trusted=trusted, agents=agents, **params).parameters
    ):
        params["seed"] = seed
    spec = load_map(name, trusted=trusted, agents=agents, **params)
    return spec if time_limit is None else with_time_limit(spec, time_limit)


def _slug(text: str) -> str:
    """A file-name-safe, unique form of a map or agent reference."""
    clean = re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("._")[:40] or "x"
    if clean == text:
        return clean
    return f"{clean}-{zlib.crc32(text.encode('utf-8')):08x}"


def episode_path(out: Path, map_name: str, agent: str, episode: int) -> Path:
    """The result file of one episode."""
    return Path(out) / "episodes" / f"{_slug(map_name)}__{_slug(agent)}__{episode:05d}.json"


def log_path(out: Path, map_name: str, agent: str, episode: int) -> Path:
    """The log file of one episode (with ``--log``)."""
    return Path(out) / "logs" / f"{_slug(map_name)}__{_slug(agent)}__{episode:05d}.parquet"


def grid_tasks(config: TrialConfig, per_map: Mapping[str, Mapping[str, Any]]) -> list[EpisodeTask]:
    """All episodes of the grid, in grid order (maps, agents, episodes)."""
    return [
        EpisodeTask(
            map=m,
            agent=a,
            episode=e,
            seed=episode_seed(config.seed, m, e),
            overrides=dict(per_map[m]),
            time_limit=config.time_limit,
            path=str(episode_path(config.out, m, a, e)),
            episode_timeout=config.episode_timeout,
            agent_ref=config.agent_refs.get(a),
            log=config.log,
            log_path=str(log_path(config.out, m, a, e)) if config.log else None,
            max_faults=config.max_faults,
            trust_map=config.trust_map,
            named_agents=dict(config.agent_refs),
        )
        for m in config.maps
        for a in config.agents
        for e in range(config.episodes)
    ]
