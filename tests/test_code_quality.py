"""The code's habits, checked wherever the tests run (CI included): ``ruff check``,
``ruff format --check`` and mypy (configured in pyproject.toml) report nothing.

The test extra pins the versions of ruff and mypy (a newer release may format or infer
differently), so these checks give the same answer on every machine.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

try:  # tests/ as a rootdir-relative package or as a plain directory on sys.path
    from tests.pins import newest_admitted
except ImportError:  # pragma: no cover
    from pins import newest_admitted

ROOT = Path(__file__).resolve().parents[1]


def _run(*command: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *command],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    "command", [("ruff", "check", "."), ("ruff", "format", "--check", ".")], ids=" ".join
)
def test_ruff_reports_nothing(command: tuple[str, ...]) -> None:
    done = _run(*command)
    assert done.returncode == 0, (done.stdout + done.stderr)[-4000:]


@pytest.mark.slow
def test_mypy_reports_nothing() -> None:
    import numpy as np

    here = ".".join(np.__version__.split(".")[:2])
    checked = newest_admitted()["numpy"]
    if here != checked:
        # numpy's type stubs (and those of libraries pinned with it) change between
        # minor versions: the check is made with the newest numpy the pins admit
        pytest.skip(f"mypy is checked with numpy {checked}, this is numpy {here}")
    done = _run("mypy")
    assert done.returncode == 0, (done.stdout + done.stderr)[-4000:]
    assert done.stdout.startswith("Success: no issues found"), done.stdout[-2000:]
