"""A source checkout imports like an installed copy.

An installed nao_arena holds the sub-packages ``nao_arena.agents`` and
``nao_arena.maps_data``, which live in a checkout in the top-level folders
``agents/`` and ``maps/`` (pyproject.toml's ``package-dir`` maps them on
install). When nao_arena is imported from a checkout that is not installed,
:func:`install` adds a finder, last on ``sys.meta_path`` (an installed or
editable copy's own finders come first), that maps those two names to the folders.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Mapping, Sequence
from importlib.abc import MetaPathFinder
from importlib.machinery import ModuleSpec
from pathlib import Path
from types import ModuleType

__all__ = ["FOLDERS", "CheckoutFinder", "install"]

FOLDERS: dict[str, str] = {"nao_arena.agents": "agents", "nao_arena.maps_data": "maps"}
"""Sub-package -> the checkout's folder that holds it (as pyproject.toml's package-dir)."""


class CheckoutFinder(MetaPathFinder):
    """Finds the mapped sub-packages in a checkout's folders."""

    def __init__(self, folders: Mapping[str, Path]) -> None:
        self.folders = dict(folders)

    def find_spec(
        self, fullname: str, path: Sequence[str] | None = None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        folder = self.folders.get(fullname)
        if folder is None:
            return None
        return importlib.util.spec_from_file_location(
            fullname, folder / "__init__.py", submodule_search_locations=[str(folder)]
        )


def install(package_dir: Path) -> bool:
    """Add the finder if ``package_dir`` (nao_arena's folder) sits in a checkout, i.e. next
    to the mapped folders and without sub-packages of those names; returns whether it did."""
    root = package_dir.parent
    folders = {name: root / folder for name, folder in FOLDERS.items()}
    if any((package_dir / name.rpartition(".")[2]).is_dir() for name in FOLDERS) or not all(
        (folder / "__init__.py").is_file() for folder in folders.values()
    ):
        return False
    if any(isinstance(f, CheckoutFinder) for f in sys.meta_path):
        return True
    sys.meta_path.append(CheckoutFinder(folders))
    return True
