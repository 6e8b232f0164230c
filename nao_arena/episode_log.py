"""Episode logs: every control step of one episode, to replay it and explain its contacts.

An :class:`EpisodeRecorder` set as an arena's ``recorder`` (see
:mod:`nao_arena.arena`) takes in the state after the reset and after every
step; :meth:`EpisodeRecorder.finish` gives the :class:`EpisodeLog`,
:func:`write_log` writes it (atomically: a temporary file in the same
folder, then ``os.replace``) and :func:`read_log` reads it back, with the
same arrays bit for bit. Recording only reads the arena: trajectories are
the same with and without it.

File format (version :data:`LOG_VERSION`)
-----------------------------------------
One Parquet file (zstd, page checksums where pyarrow writes them), one row
per body per row of the log, row-major: log row ``step`` = 0 is the state
after the reset, row ``step`` >= 1 the state at the end of control step
``step`` with the decisions applied during that step (taken at the state of
row ``step - 1``). Columns:

``step`` int32, ``time`` float64 (s, the state's time), ``body`` int16 (body
index: robots first, then traffic, map order); ``x``, ``y`` (m), ``vx``,
``vy`` (m/s), ``ax``, ``ay`` (m/s^2, the world's mean acceleration over the
step) float64: the state; ``cmd_x``, ``cmd_y`` float64 (m/s^2): the
acceleration commanded during the step (0 in row 0); ``reached`` bool: the
robot has reached its goal (statistics' flag); robots only (null for
traffic): ``status`` (string, dictionary-encoded, null in row 0): the
decision of the step, one of :data:`STATUSES`; ``selection`` (string): the
status of the agent's last full selection (agents that report one, else
null); ``detour`` float64 (rad): the agent's detour (its goal direction is
turned by it; null for agents without one); ``neighbours`` list<int32>: the
bodies the robot sensed for the decision of the step, nearest first (robots
whose agent predicts its neighbours, e.g. ``nao``; null otherwise and in
row 0).

Statuses: ``desired`` (took its desired, goal-seeking acceleration),
``kept`` (kept its current acceleration), ``repaired`` (repaired a young
adjustment locally), ``adjusted`` (a full selection: the nearest admissible
acceleration), ``infeasible`` (nothing admissible: braked, or postponed the
contact), ``fault`` (the agent failed; zero acceleration), ``external`` (an
action from outside replaced the agent), ``yielded`` (braked: its choice would have
met another robot's stopping plan, :mod:`nao_arena.stopping`). Agents that report their decisions
(``nao``, ``ao``: ``last_decision()``) get all of them; the others get
``desired`` when the command equals the goal-seeking acceleration (within
1e-9 m/s^2), else ``adjusted``.

The neighbours' predictions are not stored: they are a function of the
stored states (and of the previous step's commands, the neighbours' shared
plans) and of the robot's predictor and time grid (both in the metadata);
:meth:`EpisodeLog.decision_inputs` computes them again with the same code
the agent used.

The file's key-value metadata ``nao_arena.episode_log`` is a JSON object:
``format`` ("nao-arena episode log"), ``version``, ``nao_arena`` (the
version that wrote it), ``map`` (the resolved map: every field, parameters
and seed included), ``seed`` (the agents' seed), ``run`` (how the episode
was started: map reference, overrides, time limit, trial cell), ``options``
(the arena's sensing options), ``time_grids`` (the agents' prediction time
grids, s), ``robots`` (per robot: name, body, agent, label, predictor,
times (an index into ``time_grids``), margin (m), v_pref (m/s),
neighbours (whether its neighbours are logged)), ``steps`` (rows),
``contact_steps`` (per contact of the summary, the row that reported it),
``fault_steps``, ``summary`` (the episode's summary, as ``run --json``
writes it). ``nao_arena.episode_log.sha256`` holds the SHA-256 of that JSON
text; the states are checked against the summary's trajectory hash (with
the page checksums, a flipped bit anywhere in a log either is found or
changes nothing that is read). Reading refuses a file whose version is not :data:`LOG_VERSION`, a
truncated or corrupt one, with a one-line :class:`LogError`.
"""

from nao_arena._log_data import DecisionInputs, EpisodeLog, RobotInfo
from nao_arena._log_read import read_log
from nao_arena._log_record import EpisodeRecorder
from nao_arena._log_schema import (
    LOG_FORMAT,
    LOG_VERSION,
    SELECTIONS,
    STATUSES,
    LogError,
)
from nao_arena._log_schema import META_KEY as META_KEY
from nao_arena._log_schema import META_SHA_KEY as META_SHA_KEY
from nao_arena._log_write import to_table as to_table
from nao_arena._log_write import write_log

__all__ = [
    "LOG_FORMAT",
    "LOG_VERSION",
    "SELECTIONS",
    "STATUSES",
    "DecisionInputs",
    "EpisodeLog",
    "EpisodeRecorder",
    "LogError",
    "RobotInfo",
    "read_log",
    "write_log",
]
