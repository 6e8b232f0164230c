"""Explain a logged contact: the right pair and time, the decisions and predictions of
the step before, the picture, the command."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import imageio.v2 as iio  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from nao_arena.arena import Arena, ArenaOptions  # noqa: E402
from nao_arena.cli import main  # noqa: E402
from nao_arena.episode_log import EpisodeRecorder, read_log, write_log  # noqa: E402
from nao_arena.explain import explain_contact  # noqa: E402
from nao_arena.maps import map_from_dict  # noqa: E402
from nao_arena.trials import make_map  # noqa: E402


def record(spec, seed: int, tmp_path, options=None, max_steps=None, name="episode"):
    arena = Arena(spec, options)
    arena.recorder = EpisodeRecorder()
    summary = arena.run(seed, max_steps=max_steps)
    return summary, read_log(write_log(arena.recorder.finish(), tmp_path / f"{name}.parquet"))


@pytest.fixture(scope="module")
def goal_crowd(tmp_path_factory):
    """Four goal seekers swapping on a perturbed circle (seed 7): several contacts."""
    spec = make_map("circle_swap_perturbed", 7, {"n": 4})
    return record(
        spec, 7, tmp_path_factory.mktemp("goal"), ArenaOptions(agent="goal"), max_steps=120
    )


def test_explain_names_the_pair_and_time_of_each_goal_contact(goal_crowd):
    summary, log = goal_crowd
    robot_contacts = [c for c in summary.contacts if c.kind_b == "robot"]
    assert len(robot_contacts) >= 2
    for number, event in enumerate(summary.contacts, start=1):
        expl = explain_contact(log, number)
        assert expl.contact == event
        a, b = expl.parties
        assert (a.name, b.name) == (event.name_a, event.name_b)
        assert (a.body, b.body) == (event.a, event.b)
        # the decisions of the step before the contact, which began within the next step
        assert log.time[expl.before] < event.time <= log.time[expl.step] + 1e-9
        assert expl.step - 1 == expl.before and log.contacts_by(expl.before) < number
        assert (
            f"Contact {number} of {len(summary.contacts)} at t = {event.time:.2f} s: "
            f"{event.name_a} (goal) and {event.name_b} (goal) touched" in expl.text
        )
        assert f"At t = {log.time[expl.before]:.2f} s, the step before" in expl.text
        for p in expl.parties:
            assert p.status == "desired" and p.predictor is None
            assert np.array_equal(p.chosen, log.commanded[expl.step, p.body])
            np.testing.assert_allclose(p.desired, p.chosen, atol=1e-12)
        assert expl.text.count("took its desired, goal-seeking acceleration") == 2
    with pytest.raises(ValueError, match=f"expected 1 .. {len(summary.contacts)}"):
        explain_contact(log, len(summary.contacts) + 1)


def test_explain_a_nao_contact_shows_the_predictions(tmp_path):
    """The roundabout's one touch between two NAO robots without stopping plans (seed 16,
    turn-rate predictions): both had nothing admissible and braked; each predicted the
    other. With stopping plans (the default) the same episode has no contact."""
    spec = make_map("roundabout", 16, {"predictor": "turn_rate"})
    planned, _ = record(spec, 16, tmp_path, max_steps=90, name="planned")
    assert planned.contacts == []
    summary, log = record(
        spec, 16, tmp_path, ArenaOptions(agent_options={"stopping_plans": False}), max_steps=90
    )
    assert [(c.name_a, c.name_b) for c in summary.contacts] == [("west_east", "south_north")]
    expl = explain_contact(log, 1)
    for p, q in (expl.parties, expl.parties[::-1]):
        assert p.predictor == "turn_rate" and p.status == "infeasible"
        assert p.predicted_other is not None and p.predicted_other.shape == (31, 2)
        # its prediction, made at the step before, is the one the agent computed then
        inputs = log.decision_inputs(expl.step, p.robot)
        j = int(np.flatnonzero(inputs.observation.neighbours.ids == q.body)[0])
        assert np.array_equal(p.predicted_other, inputs.predicted[j])
        assert p.error_at_contact is not None and p.error_at_contact < 0.1
        assert np.dot(p.chosen, p.velocity) < 0  # braking
        assert f"{p.name} predicted {q.name} on an arc at its current turn rate" in expl.text
    assert expl.text.count("nothing admissible from t = ") == 2
    assert expl.text.count("braked (|a| = 3.00 m/s^2 against its velocity)") == 2


def test_explain_a_wall_contact(tmp_path):
    spec = map_from_dict(
        {
            "name": "wall",
            "bounds": {"min": [-2, -4], "max": [12, 4]},
            "walls": [{"type": "segment", "a": [5, -3], "b": [5, 3], "thickness": 0.4}],
            "robots": [{"name": "bumper", "start": [0, 0], "goal": [10, 0], "agent": "goal"}],
        }
    )
    summary, log = record(spec, 0, tmp_path, max_steps=80)
    event = summary.contacts[0]
    assert event.kind_b == "wall"
    expl = explain_contact(log, 1)
    assert [p.kind for p in expl.parties] == ["robot", "wall"]
    assert expl.text.startswith(
        f"Contact 1 of {len(summary.contacts)} at t = "
        f"{event.time:.2f} s: bumper (goal) and wall {event.b} touched"
    )


@pytest.mark.slow
def test_cli_lists_explains_and_draws(goal_crowd, tmp_path, capsys):
    summary, log = goal_crowd
    path = str(log.path)
    assert main(["explain", path]) == 0
    listing = capsys.readouterr().out
    assert listing.count(" t = ") == len(summary.contacts)
    out = tmp_path / "why.png"
    assert main(["explain", path, "--contact", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"Contact 1 of {len(summary.contacts)}") and f"wrote {out}" in printed
    picture = iio.imread(out)
    assert picture.shape[0] >= 800 and picture.shape[1] >= 1400
    assert len(np.unique(picture.reshape(-1, picture.shape[-1]), axis=0)) > 100
    assert main(["explain", path, "--contact", "99"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"nao-arena: error: {path}: --contact: expected 1 .. ")
    assert err.count("\n") == 1
