"""Real plans of the shipped scenarios, planned once per test run (workers=1)."""

from __future__ import annotations

import functools
import json
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

from planner import planning
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.resources import scenario_dir
from planner.scenario import paper
from planner.scenario.loading import load_scenario, parse_scenario
from planner.search.branch_planner import Problem
from planner.search.hcp import ConditionalPlanner
from planner.vocabulary import State

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = scenario_dir()
PAPER_NAMES = [f"paper-{i:02d}" for i in range(1, 16)]


@functools.cache
def _planned(path: str) -> str:
    return json.dumps(plan_scenario(load_scenario(path), workers=1).plan.to_json())


def plan_doc(path: Path) -> dict[str, Any]:
    """A fresh copy of the JSON of the plan of scenario `path` (planned once, then cached)."""
    doc: dict[str, Any] = json.loads(_planned(str(path)))
    return doc


def plan_of(path: Path) -> Plan:
    return Plan.from_json(plan_doc(path))


def paper_plan(name: str) -> Plan:
    return plan_of(SCENARIOS / "paper" / f"{name}.toml")


def default_plan() -> Plan:
    return plan_of(SCENARIOS / "default.toml")


# The Korean copy of the default scenario, read from this checkout (a new file is
# not in an older installed copy of the shipped scenarios).
KOREAN_DEFAULT = ROOT / "static" / "scenarios" / "default-ko.toml"


def korean_plan() -> Plan:
    return plan_of(KOREAN_DEFAULT)


def tandem_command() -> list[str]:
    # This checkout's entry point (run from ROOT); the installed console script
    # is tested on a built wheel by tests/test_packaging.py.
    return [sys.executable, "-m", "app.cli"]


def tandem(
    *args: str, env: dict[str, str] | None = None, stdin: str | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*tandem_command(), *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
        input=stdin,
        timeout=300,
    )


def free_port() -> int:
    """A loopback port nothing listens on (for a dashboard started by a test)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def family_states(family: str, n: int, workers: int) -> tuple[list[State], Problem]:
    """The states of family `family`'s instance `n` (declared feasibility) that its
    plan reaches and that are not goals, and the problem its search solved."""
    scenario = parse_scenario(paper.scenario_toml(family, n, "declared"), f"{family}{n}")
    planners: list[ConditionalPlanner] = []
    plan_scenario(scenario, workers=workers, cache_dir=":memory:", planner_hook=planners.append)
    states = [s for s, node in planners[0].nodes.items() if not node.goal]
    reachable, _ = planning.feasible_pairs(scenario, None)
    _, problem = planning._problem(scenario, reachable, [], None, ())
    return states, problem
