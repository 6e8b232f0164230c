"""The newest minor versions of the floating-point libraries that pyproject.toml admits
(each is capped just above one: ``numpy>=2.0,<2.5`` admits 2.4 at most)."""

from __future__ import annotations

import re
from pathlib import Path

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def newest_admitted() -> dict[str, str]:
    """{library: "major.minor"} for numpy, numba and pymunk, from their upper bounds."""
    out = {}
    for found in re.finditer(
        r'"(numpy|numba|pymunk)>=[\d.]+,<(\d+)\.(\d+)"', PYPROJECT.read_text()
    ):
        lib, major, minor = found.group(1), found.group(2), int(found.group(3))
        out[lib] = f"{major}.{minor - 1}"
    return out
