"""The scaling replay: a recorded run predicted on more workers."""

from __future__ import annotations

import pytest

from app.benchmark.scaling import Trace, replay, trace
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario import load_scenario


def test_a_recorded_run_replays_on_one_worker_as_it_ran() -> None:
    scenario = load_scenario(find_scenario("declared.toml"))
    run = trace(scenario, window=4)
    assert run.solves > 20 and all(len(r) <= 4 for r in run.rounds)
    # One process with the window of two workers solves what two workers solve.
    assert run.solves == plan_scenario(scenario, workers=2, window=4).solves
    solving = sum(map(sum, run.rounds))
    assert replay(run, 1) == pytest.approx(solving + run.integrate_s)
    assert replay(run, 4) < replay(run, 2) < replay(run, 1)


def test_narrow_rounds_and_integration_bound_the_speed_up() -> None:
    run = Trace(rounds=[[1.0], [1.0, 1.0, 1.0, 1.0]], integrate_s=0.5, wall_s=0.0)
    assert replay(run, 1) == pytest.approx(5.5)
    # The one-state round takes as long on any number of workers.
    assert replay(run, 4) == replay(run, 128) == pytest.approx(2.5)
    assert replay(run, 2, per_request_s=0.1) == pytest.approx(1.1 + 2.2 + 0.5)
