"""Loading maps: shipped names and files, parameters and ``$name`` substitution, the
layouts' expansion, and the checks the schema cannot make alone (agent and predictor
names, body counts, geometry: inside the bounds, clear of walls, no overlaps)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from pydantic import ValidationError

from nao_arena.agent_names import BUILTIN_AGENTS, available_agents
from nao_arena.geometry.walls import point_segment_distances
from nao_arena.maps.errors import MapError, field_error, show_value, validation_error
from nao_arena.maps.layouts import LAYOUTS, LayoutContext
from nao_arena.maps.schema import (
    MAX_BODIES,
    MAX_STEPS,
    MAX_TIME_LIMIT,
    Bounds,
    LayoutSpec,
    MapFile,
    MapSpec,
    RecordedPeople,
    ReplayedPeople,
    RobotSpec,
    SegmentWall,
    TrafficGroup,
)

__all__ = [
    "available_maps",
    "load_map",
    "map_from_dict",
    "parse_overrides",
    "with_time_limit",
]


# --------------------------------------------------------------------------- parameters


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``["n=20", "seed=3"]`` -> ``{"n": 20, "seed": 3}`` (values parsed as YAML scalars)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise MapError(f"parameter override {item!r}: expected name=value")
        try:
            out[key.strip()] = parse_yaml(value) if value.strip() else ""
        except yaml.YAMLError:
            out[key.strip()] = value
    return out


def _coerce(file: str, name: str, default: Any, value: Any) -> Any:
    if isinstance(value, str) and not isinstance(default, str):
        try:
            value = parse_yaml(value)
        except yaml.YAMLError:
            pass
    path = f"parameters.{name}"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise field_error(file, path, f"expected true or false, got {show_value(value)}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not (
            isinstance(value, int) or (isinstance(value, float) and value.is_integer())
        ):
            raise field_error(file, path, f"expected an integer, got {show_value(value)}")
        return int(value)
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise field_error(file, path, f"expected a number, got {show_value(value)}")
        return float(value)
    return str(value)


def _substitute(file: str, node: Any, params: Mapping[str, Any], path: str) -> Any:
    if isinstance(node, dict):
        return {k: _substitute(file, v, params, f"{path}.{k}".lstrip(".")) for k, v in node.items()}
    if isinstance(node, list):
        return [_substitute(file, v, params, f"{path}[{i}]") for i, v in enumerate(node)]
    if isinstance(node, str) and node.startswith("$"):
        if node.startswith("$$"):
            return node[1:]
        name = node[1:]
        if name not in params:
            declared = ", ".join(params) or "none"
            raise field_error(file, path, f"unknown parameter {node!r} (declared: {declared})")
        return params[name]
    return node


def _parameters(file: str, raw: Any, overrides: Mapping[str, Any]) -> dict[str, Any]:
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise field_error(file, "parameters", f"expected a mapping, got {show_value(raw)}")
    params: dict[str, Any] = {}
    for k, v in raw.items():
        if not isinstance(k, str) or not k.isidentifier():
            raise field_error(file, f"parameters.{k}", "expected an identifier as parameter name")
        if not isinstance(v, bool | int | float | str):
            raise field_error(
                file, f"parameters.{k}", f"expected a number, bool or string, got {show_value(v)}"
            )
        params[k] = v
    for k, v in overrides.items():
        if k not in params:
            declared = ", ".join(params) or "none"
            raise field_error(file, f"parameters.{k}", f"unknown parameter (declared: {declared})")
        params[k] = _coerce(file, k, params[k], v)
    return params


# --------------------------------------------------------------------------- checks


def _inside_convex(p: NDArray[np.float64], poly: NDArray[np.float64]) -> NDArray[np.bool_]:
    e = np.roll(poly, -1, axis=0) - poly
    rel = p[:, None, :] - poly[None]
    cross = e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


def _wall_clearance(spec: MapSpec, points: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Per wall (as listed, then bound walls): surface distance (n,) m from points to it."""
    out = []
    for w in spec.walls:
        if isinstance(w, SegmentWall):
            d = point_segment_distances(points, np.array([[w.a, w.b]], float))[:, 0]
            out.append(d - w.thickness / 2)
        else:
            poly = np.asarray(w.points, float)
            edges = np.stack([poly, np.roll(poly, -1, axis=0)], axis=1)
            d = np.min(point_segment_distances(points, edges), axis=1)
            out.append(np.where(_inside_convex(points, poly), -d, d))
    for a, b in spec.bound_wall_segments():
        d = point_segment_distances(points, np.array([[a, b]], float))[:, 0]
        out.append(d - spec.bounds.wall_thickness / 2)
    return out


def _wall_name(spec: MapSpec, k: int) -> str:
    return f"walls[{k}]" if k < len(spec.walls) else f"bounds.walls (edge {k - len(spec.walls)})"


def _check_geometry(file: str, spec: MapSpec, origins: Sequence[str]) -> None:
    """Starts, goals and routes inside the bounds and clear of walls; no overlapping bodies."""
    bounds_text = f"inside the bounds {spec.bounds.min}..{spec.bounds.max}"
    for i, r in enumerate(spec.robots):
        where = origins[i]
        if not spec.bounds.contains(np.array(r.start))[0]:
            raise field_error(
                file, f"{where}.start", f"expected a point {bounds_text}, got {r.start}"
            )
        if not spec.bounds.contains(np.array(r.goal))[0]:
            raise field_error(
                file, f"{where}.goal", f"expected a point {bounds_text}, got {r.goal}"
            )
        for j, q in enumerate(r.route or []):
            if not spec.bounds.contains(np.array(q))[0]:
                raise field_error(
                    file, f"{where}.route[{j}]", f"expected a point {bounds_text}, got {q}"
                )
    # recorded people go where the recording says: walls and overlaps are theirs
    bodies = [b for b in spec.bodies() if not b.replayed]
    if not bodies:
        return
    starts = np.array([b.start for b in bodies], float)
    radii = np.array([b.radius for b in bodies])

    first: dict[Any, int] = {}
    for b in bodies:
        first.setdefault(b.group, b.index)

    def name(k: int) -> str:
        b = bodies[k]
        if b.robot >= 0:
            return origins[b.robot]
        return f"traffic[{b.group}] (vehicle {k - first[b.group]})"

    for w, clear in enumerate(_wall_clearance(spec, starts)):
        bad = np.flatnonzero(clear < radii)
        if len(bad):
            k = int(bad[0])
            field = ".start" if bodies[k].robot >= 0 else ""
            raise field_error(
                file,
                name(k) + field,
                f"expected a start clear of the walls, but the body (radius {radii[k]:g}) "
                f"overlaps {_wall_name(spec, w)} (surface distance {clear[k]:.3g} m)",
            )
    goals = np.array([r.goal for r in spec.robots], float).reshape(-1, 2)
    rr = radii[: len(spec.robots)]
    for w, clear in enumerate(_wall_clearance(spec, goals)):
        bad = np.flatnonzero(clear < rr)
        if len(bad):
            k = int(bad[0])
            raise field_error(
                file,
                f"{origins[k]}.goal",
                f"expected a goal clear of the walls, but it overlaps {_wall_name(spec, w)}",
            )
    # pairwise start overlaps, one row at a time to bound memory
    for i in range(1, len(bodies)):
        d = np.hypot(*(starts[:i] - starts[i]).T)
        bad = np.flatnonzero(d < radii[:i] + radii[i])
        if len(bad):
            j = int(bad[0])
            same_lane = bodies[i].group >= 0 and bodies[i].group == bodies[j].group
            if same_lane:
                g = bodies[i].group
                where = f"traffic[{g}].spacing"
                what = f"vehicles {j - first[g]} and {i - first[g]} overlap"
            else:
                where = name(i) + (".start" if bodies[i].robot >= 0 else "")
                what = f"it overlaps {name(j)}"
            raise field_error(
                file,
                where,
                f"expected non-overlapping starts, but {what} "
                f"(distance {d[j]:.3g} m < {radii[i] + radii[j]:.3g} m)",
            )
    for g, grp in enumerate(spec.traffic):
        lane = grp.lane_geometry()
        s = grp.arc_positions()
        if not lane.closed and (np.min(s) < 0 or np.max(s) > lane.length):
            raise field_error(
                file,
                f"traffic[{g}].offset",
                f"expected all vehicles within the lane's length (0..{lane.length:.4g} m), "
                f"got arc lengths {np.min(s):.4g}..{np.max(s):.4g} m",
            )


# --------------------------------------------------------------------------- loading


def _shipped() -> Any:
    return resources.files("nao_arena.maps_data")


def available_maps() -> list[str]:
    """Names of the shipped maps, sorted."""
    return sorted(
        p.name.removesuffix(".yaml") for p in _shipped().iterdir() if p.name.endswith(".yaml")
    )


def _resolve(source: str | Path) -> tuple[str, str]:
    """(display name, text) of a map given by name or path."""
    text_source = str(source)
    path = Path(source)
    looks_like_path = (
        isinstance(source, Path) or text_source.endswith((".yaml", ".yml")) or ("/" in text_source)
    )
    if looks_like_path:
        if not path.is_file():
            raise MapError(f"{text_source}: no such map file")
        try:
            return text_source, path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise MapError(
                f"{text_source}: byte {exc.start}: expected UTF-8 text ({exc.reason})"
            ) from None
        except OSError as exc:
            raise MapError(f"{text_source}: cannot be read ({exc.strerror or exc})") from None
    res = _shipped() / f"{text_source}.yaml"
    if not res.is_file():
        raise MapError(
            f"{text_source}: no such map; expected a file path or one of: "
            f"{', '.join(available_maps())}"
        )
    return f"maps/{text_source}.yaml", res.read_text(encoding="utf-8")


MAX_YAML_DEPTH = 50
"""Nesting levels a map file may have (the shipped maps use at most 6)."""


class MapYamlLoader(yaml.SafeLoader):
    """YAML for map files, which hold plain data: no anchors or aliases (a few hundred
    bytes of nested aliases expand to gigabytes), no key twice in a mapping, at most
    :data:`MAX_YAML_DEPTH` levels of nesting. Each breach is a ``yaml.YAMLError`` with
    the line and column."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
            kind = "an alias (*name)" if isinstance(event, yaml.AliasEvent) else "an anchor (&name)"
            raise yaml.composer.ComposerError(
                None,
                None,
                f"{kind}: a map holds plain data, without anchors or aliases",
                event.start_mark,
            )
        self.depth += 1
        try:
            if self.depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"at most {MAX_YAML_DEPTH} levels of nesting", event.start_mark
                )
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, (str, int, float, bool)) or key is None:
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"the key {key!r} twice in one mapping", key_node.start_mark
                    )
                seen.add(key)
        return super().construct_mapping(node, deep)


def yaml_error(file: str | Path, exc: yaml.YAMLError) -> str:
    """The one-line message of a YAML file that cannot be read: the file, the line and
    column, and the problem."""
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "(top level)"
    problem = getattr(exc, "problem", None) or str(exc)
    return f"{file}: {where}: expected valid YAML ({problem})"


def parse_yaml(text: str) -> Any:
    """The data of a map's YAML text (or of a parameter's value), read with
    :class:`MapYamlLoader`. Raises ``yaml.YAMLError``."""
    return yaml.load(text, Loader=MapYamlLoader)  # a SafeLoader: plain data only


def load_map(
    source: str | Path,
    rng: np.random.Generator | None = None,
    *,
    trusted: bool = False,
    agents: Mapping[str, str] | None = None,
    **overrides: Any,
) -> MapSpec:
    """Load and validate a map by shipped name (e.g. "roundabout") or file path.

    overrides: values for the map's declared ``parameters``. rng: the
    Generator given to layout builders (default: seeded with the map's
    ``seed`` parameter, or 0). Raises :class:`MapError`.

    A map is data: its robots may name built-in agents, the agents of the
    ``nao_arena.agents`` entry point group, and the names in ``agents`` (name ->
    agent reference, given by the user: ``--agent NAME=path/to/file.py:Class``);
    an agent reference in a parameter override is the caller's and allowed too.
    A code reference the map itself holds (``path/to/file.py:Class``,
    ``module:Class``) is a :class:`MapError` unless ``trusted`` (``--trust-map``):
    loading it would run its code.
    """
    file, text = _resolve(source)
    try:
        data = parse_yaml(text)
    except yaml.YAMLError as exc:
        raise MapError(yaml_error(file, exc)) from None
    default_name = Path(file).name.removesuffix(".yaml").removesuffix(".yml")
    return map_from_dict(
        data, file, rng=rng, default_name=default_name, trusted=trusted, agents=agents, **overrides
    )


def map_from_dict(
    data: Any,
    source: str = "<dict>",
    rng: np.random.Generator | None = None,
    default_name: str = "map",
    *,
    trusted: bool = False,
    agents: Mapping[str, str] | None = None,
    **overrides: Any,
) -> MapSpec:
    """Validate a map given as plain data (as parsed from YAML); see :func:`load_map`
    (``trusted`` and ``agents`` too)."""
    file = source
    if not isinstance(data, dict):
        raise field_error(file, "(top level)", f"expected a mapping, got {show_value(data)}")
    params = _parameters(file, data.get("parameters"), overrides)
    body = {k: v for k, v in data.items() if k != "parameters"}
    body = _substitute(file, body, params, "")
    body["parameters"] = params
    try:
        mf = MapFile.model_validate(body)
    except ValidationError as exc:
        raise validation_error(file, exc, body, MapFile) from None
    callers = {v for v in overrides.values() if isinstance(v, str)}
    mf = _check_names(file, mf, AgentNames(trusted, dict(agents or {}), frozenset(callers)))
    if rng is None:
        seed = params.get("seed", 0)
        rng = np.random.default_rng(seed if isinstance(seed, int) and seed >= 0 else 0)
    robots = list(mf.robots)
    origins = [f"robots[{i}]" for i in range(len(robots))]
    _check_total(file, "robots", len(robots), "the robots placed by hand")
    for li, lay in enumerate(mf.layouts):
        robots_l, origins_l = _expand_layout(file, li, lay, mf.bounds, rng, body)
        robots.extend(robots_l)
        origins.extend(origins_l)
        _check_total(file, f"layouts[{li}]", len(robots), "this layout's robots")
    total = len(robots)
    lanes = [(g, grp) for g, grp in enumerate(mf.traffic) if isinstance(grp, TrafficGroup)]
    for g, grp in lanes:
        total += grp.count
        _check_total(file, f"traffic[{g}].count", total, "this group's vehicles")
    robots, origins = _robots_then_people(robots, origins)
    named = _named(robots)
    traffic = [
        g.model_copy(update={"offset": g.offset + float(rng.uniform(0.0, g.phase_jitter))})
        if g.phase_jitter > 0
        else g
        for _, g in lanes
    ]
    # the recorded people's start times are drawn after the lanes' phases
    starts = [(r.start, r.radius) for r in robots]
    recorded = [
        _replayed_clear_of(file, g, grp, mf, rng, starts)
        for g, grp in enumerate(mf.traffic)
        if isinstance(grp, RecordedPeople)
    ]
    for people in recorded:
        total += len(people.people)
        _check_total(file, f"traffic[{people.entry}]", total, "the people it replays")
    spec = MapSpec(
        name=mf.name or default_name,
        description=mf.description,
        source=file,
        parameters=params,
        bounds=mf.bounds,
        walls=mf.walls,
        robots=named,
        traffic=traffic,
        recorded=recorded,
        physics=mf.physics,
        episode=mf.episode,
        sensing=mf.sensing,
        actuation=mf.actuation,
        communication=mf.communication,
    )
    _check_geometry(file, spec, origins)
    _check_steps(file, "episode.time_limit", spec)
    return spec


@dataclass(frozen=True)
class AgentNames:
    """What agent names a map may use beyond the built-in and entry-point ones:
    trusted: any code reference; named: the user's names -> agent references;
    callers: the caller's own parameter values (a reference among them is allowed)."""

    trusted: bool = False
    named: Mapping[str, str] = field(default_factory=dict)
    callers: frozenset[str] = frozenset()


def _is_code_reference(name: str) -> bool:
    return ":" in name


def _check_names(file: str, mf: MapFile, names: AgentNames) -> MapFile:
    """Every robot's and layout template's agent and predictor names a known one; the
    user's names (``names.named``) replaced by their references. A code reference
    (``FILE.py:Class``, ``module:Class``) the map holds is refused unless trusted (see
    :func:`load_map`); it is loaded, and checked, when the episode starts."""
    from nao_arena.predictors import PREDICTORS

    agents: dict[str, str] | None = None

    def resolve(where: str, name: str | None) -> str | None:
        nonlocal agents
        if name is None or name in BUILTIN_AGENTS:
            return name
        if name in names.named:
            return names.named[name]
        if _is_code_reference(name):
            if names.trusted or name in names.callers:
                return name
            raise field_error(
                file,
                where,
                f"expected an agent name (built-in, plug-in, or one given with --agent "
                f"NAME=REFERENCE), got the code reference {name!r}: a map is data, and "
                "loading this would run code the map names; if you trust this map, run "
                "it with --trust-map (Python: load_map(..., trusted=True))",
            )
        agents = available_agents() if agents is None else agents
        if name not in agents:
            raise field_error(
                file,
                where,
                f"expected one of {', '.join([*agents, *names.named])}, or a name given "
                f"with --agent NAME=REFERENCE, got {name!r}",
            )
        return name

    robots = []
    for i, r in enumerate(mf.robots):
        robots.append(_resolved(r, f"robots[{i}]", resolve))
    layouts = []
    for i, lay in enumerate(mf.layouts):
        robot = _resolved(lay.robot, f"layouts[{i}].robot", resolve)
        layouts.append(lay if robot is lay.robot else lay.model_copy(update={"robot": robot}))
    for where, t in [(f"robots[{i}]", r) for i, r in enumerate(robots)] + [
        (f"layouts[{i}].robot", lay.robot) for i, lay in enumerate(layouts)
    ]:
        if t.predictor not in PREDICTORS:
            raise field_error(
                file,
                f"{where}.predictor",
                f"expected one of {', '.join(PREDICTORS)}, got {t.predictor!r}",
            )
    return mf.model_copy(update={"robots": robots, "layouts": layouts})


def _replayed(
    file: str, entry: int, group: RecordedPeople, mf: MapFile, rng: np.random.Generator
) -> ReplayedPeople:
    """The recorded people of ``traffic[entry]``: its file read (relative to the map
    file's folder), its ``time_offset`` moved by a uniform draw in [0, time_jitter) from
    ``rng`` (when time_jitter > 0), the people present for at least one control period of
    the episode."""
    from nao_arena.pedestrians import RecordingError, cached_recording

    if group.time_jitter > 0:
        shift = float(rng.uniform(0.0, group.time_jitter))
        group = group.model_copy(update={"time_offset": group.time_offset + shift})

    path = Path(group.file).expanduser()
    if not path.is_absolute() and not file.startswith("<"):
        path = Path(file).resolve().parent / path
    try:
        rec = cached_recording(path, group.format, group.fps, group.time_offset)
    except RecordingError as exc:
        raise field_error(file, f"traffic[{entry}].file", str(exc)) from None
    people = _people_in(rec, float(mf.physics.dt), float(mf.episode.time_limit))
    return ReplayedPeople(**group.model_dump(), people=people, entry=entry).model_copy(
        update={"file": str(path)}
    )


START_DRAWS = 100
"""How many start times a recorded entry with a time_jitter draws, at most, to find one at
which its people keep their ``start_clearance`` from every robot's start."""


def _replayed_clear_of(
    file: str,
    entry: int,
    group: RecordedPeople,
    mf: MapFile,
    rng: np.random.Generator,
    starts: list[tuple[tuple[float, float], float]],
) -> ReplayedPeople:
    """:func:`_replayed`, its start time drawn again (with a time_jitter) while one of its
    people in the scene is within ``start_clearance`` m (surface to surface) of a robot's
    start (``starts``: centre m and radius m each) in the first control period or, with
    ``start_clearance_for``, at any control step of that many seconds. A map whose first
    draw is clear draws what it always drew."""
    for _ in range(START_DRAWS):
        people = _replayed(file, entry, group, mf, rng)
        if group.time_jitter <= 0 or _clear_at_start(people, starts, float(mf.physics.dt)):
            return people
    within = f" for {group.start_clearance_for:g} s" if group.start_clearance_for > 0 else ""
    raise field_error(
        file,
        f"traffic[{entry}].start_clearance",
        f"expected a start time at which no recorded person is within {group.start_clearance:g} m "
        f"of a robot's start{within}; none in {START_DRAWS} draws",
    )


def _clear_at_start(
    people: ReplayedPeople, starts: list[tuple[tuple[float, float], float]], dt: float
) -> bool:
    """Whether every one of ``people`` keeps its ``start_clearance`` (m) from each robot's
    start at the control steps k dt (s) from 0 through ``start_clearance_for`` (s) at
    which it is in the scene (annotated through [k dt, (k + 1) dt], as the replay places
    it)."""
    rec = people.recording()
    steps = math.floor(people.start_clearance_for / dt + 1e-9)
    rows = np.asarray(people.people, dtype=np.intp)
    centres = np.array([xy for xy, _ in starts], dtype=np.float64).reshape(-1, 2)
    reach = np.array([r for _, r in starts], dtype=np.float64) + people.radius
    reach += people.start_clearance
    later, _ = rec.states(0.0)
    for k in range(steps + 1):
        now, later = later, rec.states((k + 1) * dt)[0]
        here = rows[np.isfinite(now[rows]).all(axis=1) & np.isfinite(later[rows]).all(axis=1)]
        gaps = np.hypot(*(now[here, None, :] - centres[None, :, :]).transpose(2, 0, 1))
        if np.any(gaps < reach[None, :]):
            return False
    return True


def _people_in(rec: Any, dt: float, end: float) -> list[int]:
    """The indices of the recording's people annotated through at least one control
    period [k dt, (k + 1) dt] of an episode of ``end`` s."""
    steps = math.ceil(end / dt - 1e-9)
    out = []
    for k in range(rec.people):
        # the first period [j dt, (j + 1) dt] that starts at or after its first annotation
        j = max(0, math.ceil(rec.first_times[k] / dt - 1e-9))
        if j < steps and rec.last_times[k] >= (j + 1) * dt:
            out.append(k)
    return out


def _robots_then_people(
    robots: list[RobotSpec], origins: list[str]
) -> tuple[list[RobotSpec], list[str]]:
    """The robots (kind "robot") in map order, then the people (kind "person") in map
    order, with where each came from."""
    order = sorted(range(len(robots)), key=lambda i: robots[i].kind == "person")
    return [robots[i] for i in order], [origins[i] for i in order]


def _named(robots: list[RobotSpec]) -> list[RobotSpec]:
    """Each robot and person with a name: its own, else ``robot<i>`` / ``person<j>`` (i, j:
    its index among the robots / the people)."""
    out = []
    counts = {"robot": 0, "person": 0}
    for r in robots:
        k = counts[r.kind]
        counts[r.kind] += 1
        out.append(r if r.name else r.model_copy(update={"name": f"{r.kind}{k}"}))
    return out


def _resolved(t: Any, where: str, resolve: Any) -> Any:
    """Robot (template) ``t`` with its agent names resolved (itself if none changed)."""
    update = {}
    for name in ("agent", "agent_options_for"):
        value = getattr(t, name)
        new = resolve(f"{where}.{name}", value)
        if new != value:
            update[name] = new
    return t.model_copy(update=update) if update else t


def _check_steps(file: str, path: str, spec: MapSpec) -> None:
    """At most :data:`MAX_STEPS` control periods in an episode of ``spec``."""
    steps = spec.episode.time_limit / spec.physics.dt
    if steps > MAX_STEPS:
        raise field_error(
            file,
            path,
            f"expected at most {MAX_STEPS} control periods per episode (time_limit / "
            f"physics.dt), got {spec.episode.time_limit:g} s / {spec.physics.dt:g} s = "
            f"{steps:.3g}",
        )


def with_time_limit(spec: MapSpec, seconds: float) -> MapSpec:
    """``spec`` with its episode time limit (s) replaced; :class:`MapError` (naming
    ``time_limit``) unless 0 < seconds <= :data:`MAX_TIME_LIMIT` with at most
    :data:`MAX_STEPS` control periods."""
    if not 0 < seconds <= MAX_TIME_LIMIT:
        raise MapError(
            f"time_limit: expected a number of s > 0 and <= {MAX_TIME_LIMIT:g}, got {seconds:g}"
        )
    episode = spec.episode.model_copy(update={"time_limit": float(seconds)})
    dt = float(spec.physics.dt)
    recorded = [
        g.model_copy(update={"people": _people_in(g.recording(), dt, float(seconds))})
        for g in spec.recorded
    ]
    spec = spec.model_copy(update={"episode": episode, "recorded": recorded})
    _check_steps(spec.source, "time_limit", spec)
    return spec


def _check_total(file: str, path: str, total: int, these: str) -> None:
    """At most :data:`MAX_BODIES` bodies up to and including ``these`` (at path)."""
    if total > MAX_BODIES:
        raise field_error(
            file,
            path,
            f"expected at most {MAX_BODIES} bodies (robots and traffic vehicles) in a map, "
            f"got {total} with {these}",
        )


def _expand_layout(
    file: str, li: int, lay: LayoutSpec, bounds: Bounds, rng: np.random.Generator, body: Any
) -> tuple[list[RobotSpec], list[str]]:
    path = f"layouts[{li}]"
    if lay.builder not in LAYOUTS:
        raise field_error(
            file,
            f"{path}.builder",
            f"expected one of {', '.join(sorted(LAYOUTS))}, got {lay.builder!r}",
        )
    model, fn = LAYOUTS[lay.builder]
    try:
        args = model.model_validate(lay.args)
    except ValidationError as exc:
        raise validation_error(file, exc, lay.args, model, prefix=f"{path}.args") from None
    try:
        placed = fn(args, LayoutContext(bounds, lay.robot.radius, rng))
    except ValueError as exc:
        raise field_error(file, path, str(exc)) from None
    prefix = lay.name or lay.builder
    robots = []
    for k, (start, goal) in enumerate(placed):
        fields = {**lay.robot.model_dump(), "start": start, "goal": goal, "name": f"{prefix}{k}"}
        try:
            robots.append(RobotSpec.model_validate(fields))
        except ValidationError as exc:
            raise validation_error(
                file, exc, fields, RobotSpec, prefix=f"{path} (robot {k})"
            ) from None
    return robots, [f"{path} (robot {k})" for k in range(len(robots))]
