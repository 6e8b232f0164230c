"""Every sub-package of nao_arena is installed by a plain (non-editable) pip install."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_listed_in_pyproject():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    on_disk = {
        ".".join(init.parent.relative_to(ROOT).parts)
        for init in (ROOT / "nao_arena").rglob("__init__.py")
    }
    assert on_disk <= listed, f"missing from [tool.setuptools] packages: {on_disk - listed}"
    assert config["package-dir"]["nao_arena.agents"] == "agents"
    assert (ROOT / "agents" / "__init__.py").is_file()


def test_import_exports_only_its_api():
    """``import nao_arena`` defines __all__ and no other public name (no `Any`, `annotations`)."""
    import os
    import subprocess
    import sys

    from conftest import PLAIN_CHECKOUT

    code = (
        "import json, nao_arena; print(json.dumps([nao_arena.__all__, "
        "[n for n in dir(nao_arena) if not n.startswith('_')]]))"
    )
    # from tests/: the installed package, or (plain checkout) the repository's
    env = dict(os.environ, PYTHONPATH=str(ROOT)) if PLAIN_CHECKOUT else None
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT / "tests",
        env=env,
    )
    exported, public = json.loads(proc.stdout)
    assert "__version__" in exported and "Arena" in exported  # the list: test_front_door.py
    assert public == sorted(n for n in exported if not n.startswith("_"))


@pytest.mark.installed
def test_version_has_one_source():
    """pyproject takes the version from nao_arena.__version__; the installed metadata agrees."""
    from importlib.metadata import version

    import nao_arena

    tomllib = pytest.importorskip("tomllib")
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in config["project"] and "version" in config["project"]["dynamic"]
    assert config["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "nao_arena.__version__"}
    assert version("nao-arena") == nao_arena.__version__


def test_license_is_an_spdx_string():
    """The table form of project.license is deprecated by setuptools (>= 77 reads the string)."""
    tomllib = pytest.importorskip("tomllib")
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert config["project"]["license"] == "MIT"
    assert "setuptools>=77" in config["build-system"]["requires"]


@pytest.mark.slow
def test_a_plain_install_has_every_file(tmp_path):
    """``pip install .`` (not editable) ships every sub-package, the mapped folders
    (agents/ as nao_arena.agents, maps/*.yaml as nao_arena.maps_data), the py.typed marker
    the kernels' manifest and the precompiled kernels."""
    import shutil
    import subprocess
    import sys

    # a copy of the sources: setuptools would reuse a stale build/ folder of the checkout
    source = tmp_path / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            ".*", "build", "dist", "*.egg-info", "__pycache__", "results", "figures"
        ),
    )
    target = tmp_path / "site"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--quiet",
            "--target",
            str(target),
            str(source),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    installed = target / "nao_arena"
    assert (installed / "py.typed").is_file()
    manifest = (ROOT / "nao_arena" / "kernels.json").read_bytes()
    assert (installed / "kernels.json").read_bytes() == manifest
    zips = sorted(p.name for p in (ROOT / "nao_arena" / "precompiled_kernels").glob("*.zip"))
    assert (
        zips and sorted(p.name for p in (installed / "precompiled_kernels").glob("*.zip")) == zips
    )
    # the installed modules have the checkout's digest: its shipped kernels are used
    probe = "from nao_arena import precompiled; print(precompiled.source_digest())"
    digest = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(target)},
    ).stdout.strip()
    assert digest == checkout_digest()
    packages = {
        init.parent.relative_to(ROOT / "nao_arena").as_posix()
        for init in (ROOT / "nao_arena").rglob("__init__.py")
    }
    for package in packages:
        assert (installed / package / "__init__.py").is_file(), package
    agents = {p.name for p in (ROOT / "agents").glob("*.py")}
    assert {p.name for p in (installed / "agents").glob("*.py")} == agents
    maps = {p.name for p in (ROOT / "maps").glob("*.yaml")}
    assert {p.name for p in (installed / "maps_data").glob("*.yaml")} == maps


def checkout_digest() -> str:
    """The source digest of this checkout's modules (:mod:`nao_arena.precompiled`)."""
    from nao_arena import precompiled

    assert Path(precompiled.__file__).resolve().is_relative_to(ROOT)
    return precompiled.source_digest()


def plain_python(tmp_path: Path) -> Path:
    """A Python that has this one's dependencies but not nao_arena: a fresh virtual
    environment whose .pth file lists this interpreter's site-packages folders (folders
    listed there are on sys.path, but their own .pth files, e.g. an editable install's,
    are not run)."""
    import site
    import subprocess
    import sys
    import venv

    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / ("Scripts/python.exe" if sys.platform == "win32" else "bin/python")
    proc = subprocess.run(
        [str(python), "-c", "import site; print(site.getsitepackages()[0])"],
        capture_output=True,
        text=True,
        check=True,
    )
    folders = [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages")]
    folders += [p for p in site.getsitepackages() if p not in folders]
    (Path(proc.stdout.strip()) / "dependencies.pth").write_text("\n".join(folders) + "\n")
    return python


@pytest.mark.slow
def test_python_m_pytest_works_in_a_plain_checkout(tmp_path):
    """``python -m pytest`` from the repository without installing nao_arena: nao_arena finds
    agents/ and maps/ as nao_arena.agents and nao_arena.maps_data by itself, and the tests
    marked ``installed`` skip."""
    import os
    import subprocess

    python = plain_python(tmp_path)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    plain = subprocess.run(
        [str(python), "-c", "import nao_arena.agents as a; print(a.__file__)"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert plain.returncode == 0, plain.stderr  # not installed there, found in the checkout
    assert plain.stdout.strip() == str(ROOT / "agents" / "__init__.py")
    proc = subprocess.run(
        [
            str(python),
            "-m",
            "pytest",
            "-q",
            "-rs",
            "-p",
            "no:cacheprovider",
            "tests/test_front_door.py",
            "tests/test_borrow.py",
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    # the one test marked `installed` (it starts a Python process) skips, and says why;
    # so does the one that reads pyproject.toml with tomllib, on Python 3.10
    skips = 1 if sys.version_info >= (3, 11) else 2
    assert f" passed, {skips} skipped" in proc.stdout, proc.stdout[-3000:]
    assert "test_borrow.py:" in proc.stdout and "needs nao_arena installed" in proc.stdout


def test_a_checkout_maps_the_folders_as_pyproject_does():
    from nao_arena._checkout import FOLDERS

    tomllib = pytest.importorskip("tomllib")
    mapping = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-dir"
    ]
    assert {name: folder for name, folder in mapping.items() if name != "nao_arena"} == FOLDERS


def test_a_checkout_works_like_an_install(tmp_path):
    """From a clone that is not installed, ``import nao_arena`` finds its maps and agents
    (the installed or editable copy of this environment hidden)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "sys.meta_path[:] = [f for f in sys.meta_path if 'editable' not in repr(f).lower()]\n"
        "sys.path[:] = [p for p in sys.path if 'site-packages' in p or 'lib/python' in p]\n"
        f"sys.path.insert(0, {str(ROOT)!r})\n"
        "import nao_arena\n"
        "assert nao_arena.__file__.startswith(sys.path[0]), nao_arena.__file__\n"
        "env = nao_arena.parallel_env('crossing')\n"
        "from nao_arena.agent import load_agent\n"
        "import inspect\n"
        "print(len(env.possible_agents), inspect.getfile(load_agent('orca')))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    robots, orca = proc.stdout.split()
    assert int(robots) == 12 and orca == str(ROOT / "agents" / "orca.py")
