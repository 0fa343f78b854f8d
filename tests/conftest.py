"""Test-wide settings: caches and stores live in temporary folders, never in $HOME."""

from __future__ import annotations

import os
import shutil
import tempfile

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
