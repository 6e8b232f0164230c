"""The trial backends: Ray gives the same results as local processes; missing Ray; CLI flags.

The Ray tests need the ``ray`` extra (``pip install nao-arena[ray]``) and are
skipped without it, unless NAO_ARENA_REQUIRE_RAY=1 (set by .ci/run, which
installs the extra): then a missing Ray fails them. They start small local Ray
instances (2 CPUs).
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from nao_arena.backends import RAY_MISSING, BackendError, LocalBackend, make_backend
from nao_arena.cli import main
from nao_arena.trials import TrialConfig, episode_path, run_trial

MAP = "circle_swap_perturbed"
GRID = [
    "--map",
    MAP,
    "--agent",
    "goal,nao",
    "--episodes",
    "3",
    "--seed",
    "5",
    "--set",
    "n=4",
    "--time-limit",
    "12",
    "--csv",
]
TABLES = ("episodes.parquet", "collisions.parquet")
TEXTS = ("summary.json", "episodes.csv", "collisions.csv", "summary.csv")


def need_ray():
    """The ray module; skip the test without it (fail if NAO_ARENA_REQUIRE_RAY=1)."""
    if os.environ.get("NAO_ARENA_REQUIRE_RAY") == "1":
        import ray

        return ray
    return pytest.importorskip("ray")


def grid(out: Path, **kw) -> TrialConfig:
    """The grid of GRID: 1 map x 2 agents x 3 episodes, 4 robots, 12 s."""
    settings = dict(
        maps=(MAP,),
        agents=("goal", "nao"),
        episodes=3,
        seed=5,
        out=out,
        overrides={"n": 4},
        time_limit=12.0,
        csv=True,
    )
    settings.update(kw)
    return TrialConfig(**settings)


def records(out: Path) -> dict[str, dict]:
    """The per-episode records, without their (informative) wall time."""
    found = {}
    for path in sorted((out / "episodes").glob("*.json")):
        rec = json.loads(path.read_text())
        rec.pop("wall_time_s")
        found[path.name] = rec
    return found


def assert_same_results(a: Path, b: Path) -> None:
    for name in TABLES:
        ta, tb = pq.read_table(a / name), pq.read_table(b / name)
        assert ta.equals(tb), name
        assert ta.to_pylist() == tb.to_pylist(), name  # same values, same order
    for name in TEXTS:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    assert records(a) == records(b)


@pytest.fixture(scope="module")
def local_run(tmp_path_factory) -> tuple[Path, list[dict]]:
    """The grid on the local backend, in this process."""
    out = tmp_path_factory.mktemp("local")
    result = run_trial(grid(out), progress=None)
    assert result.ran == 6
    return out, result.summary


# --------------------------------------------------------------------------- without Ray


def test_missing_ray_is_a_clear_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    with pytest.raises(BackendError) as exc:
        make_backend("ray")
    assert str(exc.value) == RAY_MISSING == "the ray backend needs `pip install nao-arena[ray]`"
    with pytest.raises(BackendError, match=r"pip install nao-arena\[ray\]"):
        run_trial(grid(tmp_path / "api", backend="ray"), progress=None)
    assert not (tmp_path / "api" / "episodes").exists()  # failed before anything ran
    assert main(["trial", *GRID, "--out", str(tmp_path / "cli"), "--backend", "ray"]) == 2
    assert "the ray backend needs `pip install nao-arena[ray]`" in capsys.readouterr().err
    assert not (tmp_path / "cli" / "episodes").exists()


def test_backend_settings_are_checked(tmp_path, capsys):
    assert isinstance(make_backend("local", 2), LocalBackend)
    with pytest.raises(ValueError, match="local, ray"):
        make_backend("dask")
    with pytest.raises(ValueError, match="local, ray"):
        grid(tmp_path, backend="dask")
    with pytest.raises(ValueError, match="ray backend"):
        grid(tmp_path, address="auto")
    assert main(["trial", *GRID, "--out", str(tmp_path), "--address", "auto"]) == 2
    assert "--backend ray" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["trial", *GRID, "--out", str(tmp_path), "--backend", "dask"])
    assert "invalid choice" in capsys.readouterr().err


@pytest.mark.installed
@pytest.mark.slow
def test_local_backend_does_not_import_ray(tmp_path):
    code = (
        "import sys\n"
        "from nao_arena.cli import build_parser\n"
        "from nao_arena.trials import TrialConfig, run_trial\n"
        f"run_trial(TrialConfig(maps=('{MAP}',), agents=('goal',), episodes=1, "
        f"out={str(tmp_path)!r}, overrides={{'n': 4}}, time_limit=2.0), progress=None)\n"
        "assert 'ray' not in sys.modules, 'ray imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)


# --------------------------------------------------------------------------- with Ray


@pytest.fixture
def ray():
    """The ray module (the test is skipped without it, before the local run)."""
    return need_ray()


def test_ray_gives_the_same_results_as_local(ray, local_run, tmp_path):
    if ray.is_initialized():
        ray.shutdown()
    out, summary = local_run
    seen: list[tuple[str, int]] = []
    result = run_trial(
        grid(tmp_path, backend="ray", workers=2),
        progress=None,
        on_episode=lambda r: seen.append((r["key"]["agent"], r["key"]["episode"])),
    )
    assert not ray.is_initialized()  # it started a local Ray instance, and shut it down
    assert result.ran == 6 and result.skipped == 0
    assert sorted(seen) == [(a, e) for a in ("goal", "nao") for e in range(3)]
    assert result.summary == summary
    assert [(r["map"], r["agent"]) for r in summary] == [(MAP, "goal"), (MAP, "nao")]
    assert_same_results(out, tmp_path)
    assert json.loads((tmp_path / "trial.json").read_text())["backend"] == "ray"
    assert not list(tmp_path.rglob("*.tmp"))


@pytest.fixture
def ray_session(ray):
    """A local Ray instance opened by the test (so the backend must leave it running)."""
    if ray.is_initialized():
        ray.shutdown()
    ray.init(address="local", num_cpus=2, include_dashboard=False, logging_level=logging.ERROR)
    yield ray
    ray.shutdown()


def test_cli_backend_ray_resume_and_address(ray_session, local_run, tmp_path, capsys):
    ray = ray_session
    out, _ = local_run

    # --backend ray resumes a trial begun locally: only the missing episode runs
    resumed = tmp_path / "resumed"
    shutil.copytree(out, resumed)
    episode_path(resumed, MAP, "nao", 2).unlink()
    for name in TABLES + TEXTS:
        (resumed / name).unlink()
    assert main(["trial", *GRID, "--out", str(resumed), "--backend", "ray", "--workers", "2"]) == 0
    captured = capsys.readouterr()
    assert "1 episodes run, 5 already done" in captured.out
    assert "episodes 6/6" in captured.err
    assert ray.is_initialized()  # a session opened before is left running
    assert_same_results(out, resumed)

    # --address: another process joins this Ray instance, which keeps running
    joined = tmp_path / "joined"
    address = ray.get_runtime_context().gcs_address
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_ADDRESS")}
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "nao_arena.cli",
            "trial",
            *GRID,
            "--out",
            str(joined),
            "--backend",
            "ray",
            "--address",
            address,
            "--quiet",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=180,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert "6 episodes run, 0 already done" in proc.stdout
    assert_same_results(out, joined)
    assert ray.is_initialized() and ray.cluster_resources().get("CPU") == 2


def test_a_cluster_that_loses_a_node_gives_the_same_results(ray, local_run, tmp_path):
    """A trial on a Ray cluster of two worker nodes (Ray's own test cluster, on this
    machine): one node is killed once the first episode is in, mid-trial; its episodes run
    again on the other, and every result file equals the undisturbed local run's."""
    from ray.cluster_utils import Cluster

    if ray.is_initialized():
        ray.shutdown()
    out, summary = local_run
    cluster = Cluster(
        initialize_head=True, head_node_args={"num_cpus": 0, "include_dashboard": False}
    )
    try:
        kept = cluster.add_node(num_cpus=1)
        lost = cluster.add_node(num_cpus=1)
        cluster.wait_for_nodes()
        ray.init(address=cluster.address, logging_level=logging.ERROR)
        nodes_before = {n["NodeID"] for n in ray.nodes() if n["Alive"]}
        killed: list[str] = []

        def on_episode(record: dict) -> None:
            if not killed:
                cluster.remove_node(lost, allow_graceful=False)
                killed.append(lost.node_id)

        result = run_trial(
            grid(tmp_path, backend="ray", workers=2), progress=None, on_episode=on_episode
        )
        assert killed and killed[0] in nodes_before and kept.node_id in nodes_before
        assert result.ran == 6 and result.summary == summary
        assert_same_results(out, tmp_path)
    finally:
        ray.shutdown()
        cluster.shutdown()
