"""Test-suite settings.

Hypothesis runs derandomized and without a local example database, so every
machine (and CI) runs exactly the same examples, and without its per-example deadline
(200 ms by default): tests never assert wall time, and on a machine busy with other
work one example of a property that reads a file can take longer.

A plain checkout (``python -m pytest`` without installing nao_arena) imports
``nao_arena`` from the repository, and nao_arena itself maps its sub-packages
``nao_arena.agents`` and ``nao_arena.maps_data`` to the top-level folders
``agents/`` and ``maps/`` (:mod:`nao_arena._checkout`). A Python process started by
a test does not find nao_arena there, so the tests marked ``installed`` skip.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from hypothesis import settings

import nao_arena

ROOT = Path(__file__).resolve().parents[1]

settings.register_profile("deterministic", derandomize=True, database=None, deadline=None)
settings.load_profile("deterministic")


def _plain_checkout() -> bool:
    """Whether nao_arena comes from this checkout without being installed: no finder but
    the checkout's own finds its sub-package ``nao_arena.agents``."""
    from nao_arena._checkout import CheckoutFinder

    for finder in sys.meta_path:
        find = getattr(finder, "find_spec", None)
        if isinstance(finder, CheckoutFinder) or find is None:
            continue
        if find("nao_arena.agents", list(nao_arena.__path__)) is not None:
            return False
    return True


PLAIN_CHECKOUT = _plain_checkout()
"""nao_arena is not installed: the tests marked ``installed`` skip (a child Python process
would not find it)."""


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """In a plain checkout, skip the tests marked ``installed``."""
    if not PLAIN_CHECKOUT:
        return
    skip = pytest.mark.skip(reason="plain checkout: needs nao_arena installed (pip install -e .)")
    for item in items:
        if item.get_closest_marker("installed") is not None:
            item.add_marker(skip)


def pytest_sessionstart(session: pytest.Session) -> None:
    """An installed nao_arena whose kernel cache lacks some kernels: compile them all
    first, on every core (``nao-arena compile``), instead of one by one in the tests."""
    if PLAIN_CHECKOUT:
        return
    from nao_arena.kernels import RECORD_PARTS, ensure_compiled

    report = ensure_compiled(RECORD_PARTS)
    if report is None:
        return
    print(f"\nahead of the tests: {report.summary()}", file=sys.stderr)
