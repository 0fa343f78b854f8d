"""Test-wide settings: caches and stores live in temporary folders, never in $HOME."""

from __future__ import annotations

import os
import tempfile

import pytest


def pytest_configure(config: pytest.Config) -> None:
    # Set before any test runs, so subprocesses (the CLI) inherit it too.
    os.environ["TANDEM_CACHE_DIR"] = tempfile.mkdtemp(prefix="tandem-test-cache-")
