"""benchmarks/bench_vector_env.py, a tiny run: exit status 0, a markdown table with the
bare and vector rows (and the SB3 and VMAS rows, or a note saying why not), the JSON's
rows those of the table; bad arguments give one line and exit status 2. No wall times are
checked."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_vector_env.py"


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )


def table_rows(stdout: str) -> dict[str, list[str]]:
    """The markdown table's rows by runner (header and alignment row left out)."""
    lines = [line for line in stdout.splitlines() if line.startswith("|")]
    assert lines[0].startswith("| runner |") and set(lines[1]) <= set("|:-")
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in lines[2:]]
    return {cells[0]: cells for cells in rows}


@pytest.mark.slow
def test_tiny_run_prints_the_table(tmp_path):
    out = tmp_path / "results" / "bench.json"
    proc = run(
        "--copies", "1", "2", "--sb3-copies", "2", "--steps", "5", "--repeats", "1",
        "--warmup", "2", "--vmas-envs", "2", "--json", str(out), cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    rows = table_rows(proc.stdout)
    expected = ["bare", "vector K=1", "vector K=2"]
    if importlib.util.find_spec("stable_baselines3") and importlib.util.find_spec("supersuit"):
        expected += ["sb3 vector K=2", "sb3 supersuit K=2"]
    else:
        assert "sb3 rows skipped" in proc.stdout
    with_vmas = importlib.util.find_spec("vmas") is not None
    if with_vmas:
        expected.append("vmas N=2")
    else:
        assert "vmas rows skipped" in proc.stdout and "pip install vmas" in proc.stdout
    assert list(rows) == expected
    # 10 robots per copy: 5 vector steps of K copies are 5 K env steps, 50 K agent-steps
    copies = {"bare": 1, "vector K=1": 1, "vector K=2": 2}
    for name, k in copies.items():
        assert rows[name][1:3] == [str(5 * k), str(50 * k)]
    assert rows["bare"][6] == "1.00"
    assert len(rows["bare"]) == (8 if with_vmas else 7)
    data = json.loads(out.read_text())
    assert [r["runner"] for r in data["rows"]] == expected
    for r in data["rows"]:
        cells = rows[r["runner"]]
        assert cells[1:3] == [str(r["env_steps"]), str(r["agent_steps"])]
        assert r["agent_steps_per_s"] == pytest.approx(r["agent_steps"] / r["seconds"])
        assert cells[6] == f"{r['x_bare']:.2f}"
    assert not [p for p in out.parent.iterdir() if p != out]  # no temporary file left


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--copies", "0"), "argument --copies: expected an integer >= 1, got '0'"),
        (("--steps", "0"), "argument --steps: expected an integer >= 1, got '0'"),
        (("--vmas-envs", "2", "x"), "argument --vmas-envs: expected an integer >= 1"),
        (("--repeats",), "argument --repeats: expected one argument"),
    ],
)
def test_bad_arguments_give_one_line_and_status_2(tmp_path, args, message):
    proc = run(*args, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert proc.stdout == ""
