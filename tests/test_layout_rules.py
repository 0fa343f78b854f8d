"""Rules of the code's shape that a test can see: light imports stay light."""

from __future__ import annotations

import subprocess
import sys

from tests.plan_fixtures import ROOT


def _loaded_after(module: str) -> set[str]:
    code = f"import sys, {module}; print(' '.join(sorted(sys.modules)))"
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    return set(done.stdout.split())


def test_the_world_model_loads_no_physics() -> None:
    # The world at a node is pure geometry: opening it must not start pybullet or OMPL.
    loaded = _loaded_after("app.execution.world")
    assert "pybullet" not in loaded and "ompl" not in loaded


def test_the_plan_and_the_audit_load_no_solver() -> None:
    # The audit re-simulates plans on its own: it must work without clingo.
    loaded = _loaded_after("planner.audit.branches")
    assert "clingo" not in loaded
    assert "planner.plan.model" in loaded and "planner.vocabulary" in loaded
