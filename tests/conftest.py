"""Test-suite settings.

Hypothesis runs derandomized and without a local example database, so every
machine (and CI) runs exactly the same examples.

A plain checkout (``python -m pytest`` without installing nao_arena) imports
``nao_arena`` from the repository; its sub-packages ``nao_arena.agents`` and
``nao_arena.maps_data`` live in the top-level folders ``agents/`` and ``maps/``
(pyproject's ``package-dir`` maps them on install), so they are registered here
from those folders. An installed nao_arena (imported from elsewhere) is left alone.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
from hypothesis import settings

import nao_arena

ROOT = Path(__file__).resolve().parents[1]
MAPPED = {"nao_arena.agents": ROOT / "agents", "nao_arena.maps_data": ROOT / "maps"}
"""pyproject's package-dir: sub-package -> the checkout's folder that holds it."""
REGISTERED: list[str] = []
"""The sub-packages registered here (empty when nao_arena is installed): a child Python
process does not have them, so the tests marked ``installed`` (they start one, or read the
installed metadata) skip."""

settings.register_profile("deterministic", derandomize=True, database=None)
settings.load_profile("deterministic")


def _register_checkout_packages() -> None:
    """When nao_arena comes from this checkout, make each mapped sub-package the
    checkout's folder (unless it already resolves there, as in an editable install)."""
    if Path(nao_arena.__file__).resolve().parent != ROOT / "nao_arena":
        return
    for name, folder in MAPPED.items():
        found = importlib.util.find_spec(name)
        if found is not None and found.origin is not None and (
                Path(found.origin).resolve().parent == folder):
            continue
        spec = importlib.util.spec_from_file_location(
            name, folder / "__init__.py", submodule_search_locations=[str(folder)])
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        setattr(nao_arena, name.rpartition(".")[2], module)
        REGISTERED.append(name)


_register_checkout_packages()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """In a plain checkout, skip the tests marked ``installed``."""
    if not REGISTERED:
        return
    skip = pytest.mark.skip(reason="plain checkout: needs nao_arena installed (pip install -e .)")
    for item in items:
        if item.get_closest_marker("installed") is not None:
            item.add_marker(skip)


def pytest_sessionstart(session: pytest.Session) -> None:
    """An installed nao_arena whose kernel cache lacks some kernels: compile them all
    first, on every core (``nao-arena compile``), instead of one by one in the tests."""
    if REGISTERED:
        return
    from nao_arena.kernels import RECORD_PARTS, ensure_compiled

    report = ensure_compiled(RECORD_PARTS)
    if report is None:
        return
    print(f"\ncompiled {report.kernels} kernels ahead in {report.seconds:.0f} s "
          f"with {report.jobs} processes", file=sys.stderr)
