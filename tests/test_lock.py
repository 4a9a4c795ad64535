"""The locked set-up: uv.lock holds every dependency pyproject.toml names (runtime and the
dev extra) at a version its specifier allows, scripts/uv-requirements.txt pins the lock's
uv with hashes, the set-up reinstalls when the lock changes, and the environment running
the tests holds exactly the locked versions (skipped under scripts/test-latest, which runs
the newest on purpose)."""

from __future__ import annotations

import importlib.metadata as md
import os
import re
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.markers import Marker
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

REPO = Path(__file__).resolve().parents[1]


def _lock() -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for p in tomllib.loads((REPO / "uv.lock").read_text())["package"]:
        out.setdefault(canonicalize_name(p["name"]), []).append(p)
    return out


def _requirements() -> list[Requirement]:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    return [Requirement(r) for r in project["dependencies"] + project["optional-dependencies"]["dev"]]


def test_lock_holds_every_dependency_at_an_allowed_version():
    lock = _lock()
    names = set()
    for req in _requirements():
        name = canonicalize_name(req.name)
        names.add(name)
        assert name in lock, f"{req.name} is in pyproject.toml but not in uv.lock: run scripts/upgrade-lock"
        versions = [p["version"] for p in lock[name]]
        assert any(req.specifier.contains(v, prereleases=True) for v in versions), (req, versions)
        for p in lock[name]:
            assert p["source"] == {"registry": "https://pypi.org/simple"}, p["source"]
            assert all("hash" in w for w in p.get("wheels", [])), f"{name}: a wheel without a hash"
    assert {"x3pio", "prysm", "h5py", "surfalize", "dask", "distributed", "pytest-xdist",
            "mkdocs-material", "mkdocstrings", "mkdocstrings-python"} <= names | set(lock)


def test_bootstrap_pins_the_locks_uv_with_hashes_and_watches_the_lock():
    (uv,) = _lock()["uv"]
    text = (REPO / "scripts" / "uv-requirements.txt").read_text()
    assert re.search(rf"^uv=={re.escape(uv['version'])} \\$", text, re.M), "run scripts/upgrade-lock"
    assert text.count("--hash=sha256:") >= 5
    bootstrap = (REPO / "scripts" / "bootstrap").read_text()
    stamp_line = next(line for line in bootstrap.splitlines() if line.startswith("want="))
    for watched in ("pyproject.toml", "uv.lock", "scripts/uv-requirements.txt"):
        assert watched in stamp_line
    assert "--require-hashes" in bootstrap and "uv sync --locked" in bootstrap


@pytest.mark.skipif(bool(os.environ.get("LATHE_MIRROR_LATEST")), reason="scripts/test-latest: newest on purpose")
def test_environment_holds_exactly_the_locked_versions():
    lock = _lock()
    # Only what is installed: setuptools puts its vendored copies (setuptools/_vendor, with
    # their own dist-info) on sys.path once pkg_resources is imported (prysm does), and
    # those are not the environment's packages.
    paths = [p for p in sys.path if "_vendor" not in Path(p).parts]
    installed = {canonicalize_name(d.metadata["Name"]): d.version for d in md.distributions(path=paths)}
    wrong = {}
    for name, entries in lock.items():
        if name == "lathe-mirror":
            continue
        for p in entries:
            marker = p.get("resolution-markers")
            if marker and not any(Marker(m).evaluate() for m in marker):
                continue
            if name in installed and installed[name] != p["version"] and not any(
                    q["version"] == installed[name] for q in entries):
                wrong[name] = (installed[name], [q["version"] for q in entries])
    assert not wrong, f"installed against uv.lock: {wrong} (scripts/bootstrap installs the lock)"
