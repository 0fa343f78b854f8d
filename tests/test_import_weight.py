"""Reading sessions, checking a scenario and asking for help load neither the
solver, the physics engine, the motion planner, the dashboard nor the cluster.

`tandem sessions list` on a laptop without a planner's worth of memory, a review
of a study's store, and the walker (which takes its repair as a function) must
not pay for them. The commands are run as a user runs them, through the `tandem`
script, with Python's import profile on; the library modules are each imported
in a fresh interpreter and its `sys.modules` checked.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from app.benchmark.startup import HEAVY, imported
from planner.resources import scenario_path

LIGHT_MODULES = (
    "app.sessions.store",
    "app.sessions.summary",
    "app.cli.sessions",
    "app.execution.events",
    "app.execution.walker",
)


def _loaded(module: str) -> list[str]:
    code = (
        f"import json, sys, {module}\n"
        f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded: list[str] = json.loads(done.stdout)
    return loaded


@pytest.mark.parametrize("module", LIGHT_MODULES)
def test_module_loads_no_solver_and_no_physics(module: str) -> None:
    assert _loaded(module) == []


def test_the_check_itself_sees_a_heavy_import() -> None:
    """The planning pipeline does load clingo: the probe above can see it."""
    assert "clingo" in _loaded("planner.planning")


@pytest.mark.parametrize(
    "command",
    [["--help"], ["sessions", "list"], ["scenario", "check", str(scenario_path("default.toml"))]],
    ids=["help", "sessions list", "scenario check"],
)
def test_a_light_command_loads_nothing_heavy(command: list[str], tmp_path: Path) -> None:
    argv = [*command, "--data-dir", str(tmp_path)] if command[0] == "sessions" else command
    loaded = imported(argv)
    assert "app" in loaded  # the profile saw the program's own imports
    assert loaded & set(HEAVY) == set()


def test_the_command_probe_sees_a_heavy_import() -> None:
    """`tandem plan` loads the solver, even for its help: the probe above can see it."""
    assert "clingo" in imported(["plan", "--help"])
