"""Experiments as files: ``nao-arena trial --config exp.yaml``.

A study lives in version control as one YAML file holding what ``trial`` takes on its
command line (the keys are the options' names without ``--``, plurals for the lists)::

    maps: [crossing, roundabout]          # shipped names or map files
    agents: [nao, orca, mine=agents/mine.py:Mine]
    episodes: 20
    seed: 0
    out: results/exp1                     # the results folder
    set: {n: 8}                           # map parameters
    time_limit: 30.0                      # s
    episode_timeout: 600                  # s (0 or null: none)
    max_faults: 10
    log: contacts                         # all | contacts | null
    csv: true
    workers: 2
    backend: local                        # local | ray
    address: null
    retry_failed: false
    trust_map: false

Only ``maps``, ``agents`` and ``out`` are required. Relative paths in it (``out``, map
files, agent files) are relative to the file's folder, so the study and its files move
together. Options given on the command line override the file's. The file is read as
plain data (the map loader's rules: no anchors or aliases, no key twice); every problem
is one line naming the file, the key and what was expected (:class:`ExperimentError`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from nao_arena.maps.errors import MapError, validation_error
from nao_arena.maps.loader import parse_yaml, yaml_error
from nao_arena.maps.schema import MAX_TIME_LIMIT, Num

__all__ = ["Experiment", "ExperimentError", "read_experiment"]


class ExperimentError(MapError):
    """An experiment file that cannot be read (one line: file, key, what was expected)."""


Names = Annotated[list[Annotated[str, Field(min_length=1)]], Field(min_length=1)]


class Experiment(BaseModel):
    """The keys of an experiment file (see the module)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)

    maps: Names
    agents: Names
    out: Annotated[str, Field(min_length=1)]
    episodes: Annotated[int, Field(ge=1)] = 10
    seed: Annotated[int, Field(ge=0)] = 0
    workers: Annotated[int, Field(ge=1)] = 1
    set: dict[str, Any] = Field(default_factory=dict)
    time_limit: Annotated[Num, Field(gt=0, le=MAX_TIME_LIMIT)] | None = None
    episode_timeout: Annotated[Num, Field(ge=0)] | None = 600.0
    max_faults: Annotated[int, Field(ge=0)] | None = None
    log: Literal["all", "contacts"] | None = None
    csv: bool = False
    backend: Literal["local", "ray"] = "local"
    address: str | None = None
    retry_failed: bool = False
    trust_map: bool = False


def read_experiment(path: str | Path) -> Experiment:
    """The experiment in the YAML file ``path``, its relative paths made relative to the
    file's folder. Raises :class:`ExperimentError`."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ExperimentError(f"{file}: no such experiment file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ExperimentError(f"{file}: cannot be read ({exc})") from None
    try:
        data = parse_yaml(text)
    except yaml.YAMLError as exc:
        raise ExperimentError(yaml_error(file, exc)) from None
    if not isinstance(data, dict):
        raise ExperimentError(f"{file}: (top level): expected a mapping of trial options")
    for key in ("maps", "agents"):
        if isinstance(data.get(key), str):  # "a,b" as on the command line
            data[key] = [part.strip() for part in data[key].split(",") if part.strip()]
    try:
        experiment = Experiment.model_validate(data)
    except ValidationError as exc:
        raise ExperimentError(str(validation_error(str(file), exc, data, Experiment))) from None
    return _relative_to(experiment, file.parent)


def _relative_to(experiment: Experiment, folder: Path) -> Experiment:
    """Relative paths of ``experiment`` (out, map files, agent files) joined to ``folder``."""

    def place(text: str) -> str:
        path = Path(text)
        return text if path.is_absolute() else str(folder / path)

    def map_path(name: str) -> str:
        return place(name) if name.endswith((".yaml", ".yml")) else name

    def agent_path(text: str) -> str:
        label, sep, ref = text.rpartition("=") if "=" in text.split(":", 1)[0] else ("", "", text)
        target, colon, cls = ref.rpartition(":")
        if colon and target.endswith(".py"):
            ref = f"{place(target)}:{cls}"
        return f"{label}{sep}{ref}"

    return experiment.model_copy(
        update={
            "out": place(experiment.out),
            "maps": [map_path(m) for m in experiment.maps],
            "agents": [agent_path(a) for a in experiment.agents],
        }
    )
