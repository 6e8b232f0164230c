"""benchmarks/bench_nao_step.py, a tiny run: exit status 0 and one row per size, both
ways of running the nao agents' step timed on the same trajectory (the script stops
otherwise); bad arguments give one line and exit status 2. No wall times are checked."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_nao_step.py"


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], cwd=cwd, capture_output=True, text=True, timeout=300
    )


def test_a_tiny_run_prints_a_row_per_size(tmp_path: Path) -> None:
    out = run("--sizes", "2,3", "--repeats", "1", cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.strip().splitlines()
    assert lines[0].split() == [
        "robots", "steps", "one", "call", "us", "one", "by", "one", "us", "ratio", "agents", "%",
    ]  # fmt: skip
    rows = [line.split() for line in lines[1:]]
    assert [r[0] for r in rows] == ["2", "3"]
    for r in rows:
        steps, one_call, one_by_one, ratio = int(r[1]), float(r[2]), float(r[3]), float(r[4])
        assert steps > 0 and one_call > 0 and one_by_one > 0
        assert abs(ratio - one_call / one_by_one) < 0.01
        assert 0 < float(r[5]) < 100


def test_bad_arguments_give_one_line_and_status_2(tmp_path: Path) -> None:
    for args in (["--repeats", "0"], ["--sizes", "2,x"], ["--sizes", ","], ["--bogus"]):
        out = run(*args, cwd=tmp_path)
        assert out.returncode == 2, args
        lines = out.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("bench_nao_step.py: error: "), args
