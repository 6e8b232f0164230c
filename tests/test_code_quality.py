"""The code's habits, checked wherever the tests run (CI included): ``ruff check``,
``ruff format --check`` and mypy (configured in pyproject.toml) report nothing.

The test extra pins the versions of ruff and mypy (a newer release may format or infer
differently), so these checks give the same answer on every machine.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

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


def _numpy_cap_minor() -> str:
    """The newest numpy minor version pyproject.toml admits (``numpy>=2.0,<2.5``: 2.4)."""
    text = (Path(__file__).parents[1] / "pyproject.toml").read_text()
    found = re.search(r'"numpy>=[\d.]+,<(\d+)\.(\d+)"', text)
    assert found, "pyproject.toml: no numpy requirement with an upper bound"
    return f"{found.group(1)}.{int(found.group(2)) - 1}"


@pytest.mark.slow
def test_mypy_reports_nothing() -> None:
    import numpy as np

    here = ".".join(np.__version__.split(".")[:2])
    if here != _numpy_cap_minor():
        # numpy's type stubs (and those of libraries pinned with it) change between
        # minor versions: the check is made with the newest numpy the pins admit
        pytest.skip(f"mypy is checked with numpy {_numpy_cap_minor()}, this is numpy {here}")
    done = _run("mypy")
    assert done.returncode == 0, (done.stdout + done.stderr)[-4000:]
    assert done.stdout.startswith("Success: no issues found"), done.stdout[-2000:]
