"""Map files: schema, parameters, layout builders and the loader.

A map is one YAML file (shipped maps live in the package
``nao_arena.maps_data``, the repository's ``maps/`` folder). Units: metres,
seconds, m/s, m/s^2, kg, radians; all coordinates in the world frame.
Unknown keys are errors everywhere.

Numbers are finite (``.inf`` and ``.nan`` are errors); an integer is
accepted where a number is expected, but ``true``/``false`` never are.
Counts are integers >= 1. These checks apply after parameters are
substituted, so an override cannot get round them. Bounds that keep a
map from hanging or exhausting memory: at most :data:`MAX_BODIES` (10000)
bodies (robots and traffic vehicles) in a map, hence in one layout
(``n``) or lane (``count``); ``physics.substeps`` and
``physics.iterations`` at most :data:`MAX_SUBSTEPS` and
:data:`MAX_ITERATIONS` (1000 each); the ``crowd`` builder's ``max_tries``
at most :data:`MAX_TRIES` (1000000).

Top level
---------
``name`` (str, optional): the map's name (default: the file stem).
``description`` (str, optional).
``parameters`` (mapping name -> number, bool or string, optional): tunable
    values with their defaults. Anywhere else in the file, a value that is
    exactly the string ``"$name"`` is replaced by the parameter's value
    (whole values only; ``"$$x"`` stands for the literal string ``"$x"``).
    ``load_map(name, n=20)`` and the command line (``n=20``, see
    :func:`parse_overrides`) override declared parameters; the override is
    converted to the type of the default. The parameter ``seed`` (if
    declared) seeds the ``numpy.random.Generator`` given to layout builders.
``bounds``: ``min: [x, y]``, ``max: [x, y]`` (m), the arena's extent; robot
    starts, goals and route points must lie inside. ``walls: true`` closes
    the bounds with four segment walls of ``wall_thickness`` (m, default 0.2)
    centred on the boundary.
``walls`` (list, optional): static walls, each one of
    ``{type: segment, a: [x, y], b: [x, y], thickness: t}`` (a segment of
    thickness t m, default 0.2, i.e. a capsule of radius t/2), or
    ``{type: polygon, points: [[x, y], ...]}`` (a convex polygon, >= 3 points).
``robots`` (list, optional): robots placed by hand, each with
    ``start: [x, y]`` (m), ``goal: [x, y]`` (m) and/or ``route`` (list of
    waypoints [x, y] m; the goal defaults to the last one), ``velocity``
    (initial, m/s, default [0, 0]), ``radius`` (m, default 0.3), ``mass``
    (kg, default 1), ``a_max`` (m/s^2, default 2), ``v_max`` (m/s, default
    1.5), ``agent`` (default "nao": a built-in or plug-in agent name, checked
    when the map loads, or ``path/to/file.py:Class`` / ``module:Class``,
    checked when the agent is loaded), ``predictor`` (default "turn_rate",
    one of :data:`nao_arena.predictors.PREDICTORS`), ``agent_options``
    (keyword options of the agent's constructor, e.g. ``{horizon: 5.0}``),
    ``agent_options_for`` (the agent those options are for, e.g. "nao": a robot
    that runs another agent gets none of them; default: any agent that takes them),
    ``kind`` (``robot``, the default: a robot under test; ``person``: a simulated
    pedestrian driven by its own agent, e.g. ``social_force``, reported apart, left
    alone by ``--agent`` and the env, and counted by the robots' agents as a body that
    does not cooperate; people come after the robots in body order), ``name``
    (default "robot<i>", "person<i>" for people).
``layouts`` (list, optional): generated robots, each
    ``{builder: <name>, args: {...}, robot: {...}, name: prefix}``, where
    ``builder`` names a registered layout builder (:data:`LAYOUTS`),
    ``args`` are its arguments (below) and ``robot`` holds the shared robot
    settings (radius, mass, a_max, v_max, agent, predictor). Builders:

    - ``circle_swap``: ``n`` robots (default 10) evenly on a circle of
      ``radius`` (m, default 8) around ``center`` (default [0, 0]), the first
      at ``angle`` (rad, default 0); each goes to the antipodal point;
      ``arc_spacing`` (m, optional) grows the circle so that neighbours are
      at least that far apart along it: radius max(radius, n arc_spacing /
      (2 pi)) (radius 10, arc_spacing 2.2: the RVO2/AVO2 rule max(10, 1.1 n / pi));
      ``perturb`` (m, default 0) displaces each start uniformly within a disc
      of that radius (seeded).
    - ``crowd``: ``n`` robots (default 20) with random starts and goals drawn
      uniformly in the square ``region_min``..``region_max`` (default: the
      bounds inset by the robot radius + ``min_gap``), at least ``min_gap``
      (m, default 0.2) apart surface to surface, start and goal at least
      ``min_travel`` (m, default 0) apart; it gives up after ``max_tries``
      random draws for the starts, or for the goals (default 100000, at
      most 1000000).
    - ``stream``: ``n`` robots in a block ``width`` abreast (default 1),
      ``spacing`` (m) between centres, the block's front centre at
      ``origin``, heading along ``direction`` ([dx, dy], normalized); each
      goal is its start moved ``distance`` (m) along ``direction``;
      ``perturb`` (m, default 0) displaces each start (and its goal)
      uniformly within a disc of that radius (seeded).
    - ``queue``: the robots of ``stream`` (same arguments, the same starts
      and draws) with their goals in a block of the same kind: ``goal_width``
      abreast (default ``width``), ``goal_spacing`` (m, required) between
      centres, its front row ``distance`` m ahead of the starts' front row
      (robot k takes goal k: the first robots head for the farthest goals);
      ``perturb`` moves each start and its goal alike. A queue that spreads
      out on arrival, so that a robot can pass between parked ones.
    - ``circle_crossing`` (CrowdNav's circle crossing): ``n`` bodies (default 5) at
      random angles on a circle of ``radius`` (m, default 4) around ``center``, each
      start moved by a uniform draw in [-``noise``/2, ``noise``/2] (m, default 1) per
      axis, each goal the start's reflection through the centre; starts (and goals)
      at least two radii + ``min_gap`` (m, default 0.2) from one another and from the
      points of ``keep_clear`` (e.g. a robot's start and goal), drawn again until
      they are (at most ``max_tries`` draws, default 100000).
    - ``square_crossing`` (CrowdNav's square crossing): ``n`` bodies (default 5) in a
      square of side ``width`` (m, default 10) around ``center``, each starting in a
      random half (left or right of the vertical axis) and heading for a random
      point of the other half; ``min_gap``, ``keep_clear`` and ``max_tries`` as for
      ``circle_crossing``.
``traffic`` (list, optional): scripted vehicles, one group per lane:
    ``lane``: ``{type: circle, center: [x, y], radius: R, direction: ccw|cw,
    start_angle: rad}`` or ``{type: polyline, points: [[x, y], ...], closed:
    bool}``; ``speed`` (cruise, m/s); ``count`` (default 1); ``spacing`` (m of
    arc length between consecutive vehicles; default: the lane length /
    count on a closed lane, required on an open lane with count > 1);
    ``offset`` (m, arc length of vehicle 0, default 0; vehicle k is at
    offset + k spacing); ``phase_jitter`` (m, default 0: the whole group is
    shifted along its lane by a uniform draw in [0, phase_jitter) from the
    map's seeded Generator, after the layouts have drawn theirs); ``radius``
    (m, default 1), ``mass`` (kg, default 1000), ``a_max`` (m/s^2, default
    3), ``v_max`` (m/s, default 1.5 speed, must exceed speed), car
    following: ``time_headway`` (s, default 1), ``min_gap`` (m, default 2),
    ``name``.
    An entry with ``type: recorded`` replays recorded people instead (ETH/UCY
    annotations, :mod:`nao_arena.pedestrians`): ``file`` (the recording; a relative
    path is relative to the map file), ``format`` (``obsmat``, default: ``frame id x z
    y vx vz vy``; or ``xy``: ``frame id x y``), ``fps`` (frames per second of its frame
    numbers, default 15), ``time_offset`` (s, default 0: the recording's time at which
    the episode starts), ``time_jitter`` (s, default 0: the offset moved by a uniform
    draw in [0, time_jitter) from the map's seeded Generator, after the lanes' phases),
    ``start_clearance`` (m, default 0: with a time_jitter, the draw is made again while a
    person in the scene at the start is within this distance, surface to surface, of a
    robot's start), ``start_clearance_for`` (s, default 0, at most 60: the clearance
    holds at every control step of this long, for a robot standing at its start),
    ``radius`` (m, default 0.3), ``name`` (prefix of the people's names, default
    "person", then the recording's id). Each person present for at least one
    whole control period is a body of kind ``person`` that the recording moves (a pymunk
    kinematic body): at every control step at its recorded centre (interpolated
    linearly between annotations), in between along the chord to the next one; it is
    in the scene for the control periods it is annotated through, and waits far
    outside the bounds (out of sensing range) before and after. A recording cannot
    react, so its contacts are counted but not resolved: it pushes nothing and nothing
    pushes it (the two pass through each other); its contacts with other recorded
    people and with walls are not counted. The ``known_path`` predictor (the oracle)
    reads its true future from the recording.
``physics``: ``dt`` (control period, s, default 0.1), ``substeps`` (1..1000,
    default 10), ``elasticity`` (0..1, default 0.2), ``friction`` (>= 0,
    default 0), ``collision_slop`` (m of tolerated overlap, default 0.005),
    ``iterations`` (solver iterations per physics step, 1..1000, default 10).
``episode``: ``time_limit`` (s, > 0, default 60), ``goal_tolerance`` (m from
    the goal at which a robot has arrived, default 0.3).
``sensing``: ``range`` (m, default 30): robots sense the bodies within it;
    ``max_neighbours`` (default: no limit), the nearest first; ``latency`` (s,
    default 0): the agents act on what they sensed that long ago (whole control
    periods; the statistics use the truth); ``noise``: ``{position: m, velocity:
    m/s, acceleration: m/s^2}`` (each default 0), the standard deviations of
    Gaussian noise added to each component of what a robot senses of each
    neighbour, drawn per robot, neighbour and step (its own state stays exact);
    ``dropout`` (probability 0..1, default 0): each neighbour of each robot is
    missed in a step with that probability, independently; ``field_of_view`` (rad,
    > 0 and <= 2 pi, default 2 pi: all around): a robot senses only the bodies whose
    centre lies within half that angle of its heading (the direction of its
    velocity; standing still, the direction to its goal), the nearest
    ``max_neighbours`` of them; ``occlusion`` (default false): a robot senses only the
    bodies it can see past the other bodies and the walls in front of them (exact disc
    and wall shadows, :mod:`nao_arena.occlusion`). Random draws come from the episode's
    generator.
``actuation``: ``noise`` (m/s^2, default 0): the standard deviation of Gaussian noise
    added to each component of every robot's command each control period (the
    episode's generator); ``lag`` (s, default 0): the time constant of a first-order
    response of the applied acceleration a to the (noisy) command c, a += (1 -
    exp(-dt / lag)) (c - a) each control period (a = 0 at the start); both before
    the world's limits.
``communication``: what cooperative robots share (their states and plans; see
    :mod:`nao_arena.communication`): ``range`` (m, default null: no limit; .inf too),
    ``latency`` (s, default 0, whole control periods), ``loss`` (probability 0..1,
    default 0) that a pair's exchange of a control period is lost; ``off`` (or
    ``false``): nothing is shared; the default is perfect communication.

Body order (the world's, the stats', the agents'): hand-placed robots,
then layout robots (layout by layout), then the people (``kind: person``, in
the same order), then traffic (group by group, vehicle 0 first), then the
recorded people (entry by entry, in the recording's id order).

Errors are :class:`MapError` (a ``ValueError``) naming the file, the field
path and what was expected, e.g. ``maps/foo.yaml: robots[2].radius:
expected a positive number, got -1``.
"""

# The package: schema (the models and limits), layouts (the builders), errors (MapError
# and its messages), loader (parameters, checks, load_map) and reference (the format as
# text). Everything is importable from nao_arena.maps.

from nao_arena.maps.errors import MapError
from nao_arena.maps.layouts import LAYOUTS, LayoutContext, Placement, register_layout
from nao_arena.maps.loader import (
    available_maps,
    load_map,
    map_from_dict,
    parse_overrides,
    with_time_limit,
)
from nao_arena.maps.reference import format_reference, sections
from nao_arena.maps.schema import (
    MAX_BODIES,
    MAX_DT,
    MAX_ITERATIONS,
    MAX_MAGNITUDE,
    MAX_STEPS,
    MAX_SUBSTEPS,
    MAX_TIME_LIMIT,
    MAX_TRIES,
    MIN_DT,
    Actuation,
    BodySpec,
    Bounds,
    CircleLaneSpec,
    CommunicationSpec,
    Episode,
    LayoutSpec,
    MapFile,
    MapSpec,
    Physics,
    PolygonWall,
    PolylineLaneSpec,
    RobotSpec,
    RobotTemplate,
    SegmentWall,
    Sensing,
    SensingNoise,
    TrafficGroup,
)

__all__ = [
    "LAYOUTS",
    "Actuation",
    "MAX_BODIES",
    "MAX_DT",
    "MAX_ITERATIONS",
    "MAX_MAGNITUDE",
    "MAX_STEPS",
    "MAX_SUBSTEPS",
    "MAX_TIME_LIMIT",
    "MAX_TRIES",
    "MIN_DT",
    "BodySpec",
    "Bounds",
    "CircleLaneSpec",
    "CommunicationSpec",
    "Episode",
    "LayoutContext",
    "LayoutSpec",
    "MapError",
    "MapFile",
    "MapSpec",
    "Physics",
    "Placement",
    "PolygonWall",
    "PolylineLaneSpec",
    "RobotSpec",
    "RobotTemplate",
    "SegmentWall",
    "Sensing",
    "SensingNoise",
    "TrafficGroup",
    "available_maps",
    "format_reference",
    "load_map",
    "map_from_dict",
    "parse_overrides",
    "register_layout",
    "with_time_limit",
]

# earlier private names, still used by the tests
_MapFile = MapFile
_sections = sections
