"""Reading sessions and walking a plan load neither the solver nor the physics engine.

`tandem sessions list` on a laptop without a planner's worth of memory, a review
of a study's store, and the walker (which takes its repair as a function) must
not pay for clingo or pybullet: each module is imported in a fresh interpreter
and its `sys.modules` checked.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("clingo", "pybullet", "ompl")
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
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    loaded: list[str] = json.loads(done.stdout)
    return loaded


@pytest.mark.parametrize("module", LIGHT_MODULES)
def test_module_loads_no_solver_and_no_physics(module: str) -> None:
    assert _loaded(module) == []


def test_the_check_itself_sees_a_heavy_import() -> None:
    """The planning pipeline does load clingo: the probe above can see it."""
    assert "clingo" in _loaded("planner.planning")
