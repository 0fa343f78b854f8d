"""Test-wide settings: caches and stores live in temporary folders, never in $HOME."""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

_made: list[str] = []


def pytest_configure(config: pytest.Config) -> None:
    # Set before any test runs, so subprocesses (the CLI) inherit it too.
    folder = tempfile.mkdtemp(prefix="tandem-test-cache-")
    _made.append(folder)
    os.environ["TANDEM_CACHE_DIR"] = folder


def pytest_unconfigure(config: pytest.Config) -> None:
    for folder in _made:
        shutil.rmtree(folder, ignore_errors=True)
