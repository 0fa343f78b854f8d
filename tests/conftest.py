"""Test-wide settings: caches and stores live in temporary folders, never in $HOME."""

from __future__ import annotations

import os
import shutil
import tempfile
import types

import pytest

_made: list[str] = []


def pytest_configure(config: pytest.Config) -> None:
    # Set before any test runs, so subprocesses (the CLI) inherit it too.
    for variable in ("TANDEM_CACHE_DIR", "TANDEM_DATA_DIR"):
        folder = tempfile.mkdtemp(prefix=f"tandem-test-{variable[7:11].lower()}-")
        _made.append(folder)
        os.environ[variable] = folder


def pytest_unconfigure(config: pytest.Config) -> None:
    for folder in _made:
        shutil.rmtree(folder, ignore_errors=True)


# What a module's tests need, read off what the module uses: a test that drives
# chromium is `browser`, one on a roscore `ros`, one on Ray `cluster`. Marked here
# so a new test file is marked without anyone remembering to.
_NEEDS: dict[str, tuple[str, ...]] = {
    "browser": ("playwright",),
    "ros": ("robot_graph", "tests.robot_graph"),
    "cluster": ("ray",),
}


def _uses(module: types.ModuleType, prefixes: tuple[str, ...]) -> bool:
    for value in vars(module).values():
        name = value.__name__ if isinstance(value, types.ModuleType) else getattr(
            value, "__module__", None
        )
        if isinstance(name, str) and (name in prefixes or name.split(".")[0] in prefixes):
            return True
    return False


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    seen: dict[str, set[str]] = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is None:
            continue
        if module.__name__ not in seen:
            seen[module.__name__] = {m for m, p in _NEEDS.items() if _uses(module, p)}
        for marker in seen[module.__name__]:
            item.add_marker(marker)
        # Under pytest-xdist (--dist loadgroup) a file's tests share one worker and
        # so its module fixtures (a server, a browser); Ray's tests share one worker
        # so two local clusters never meet through `address="auto"`.
        group = "cluster" if "cluster" in seen[module.__name__] else module.__name__
        item.add_marker(pytest.mark.xdist_group(group))
