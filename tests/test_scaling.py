"""The scaling replay: a recorded run predicted on more workers."""

from __future__ import annotations

import pytest

from app.benchmark.scaling import Trace, replay, trace
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario


def in_flight(run: Trace) -> int:
    """The most solves ever pending at once in `run` (asked, not yet integrated)."""
    return max(run.pending(k) for k in range(len(run.solves)))


def test_a_recorded_run_replays_on_one_worker_as_it_ran() -> None:
    scenario = load_scenario(find_scenario("declared.toml"))
    run = trace(scenario, window=4)
    assert len(run.solves) > 20 and in_flight(run) == 4
    # One process with the window of two workers solves what two workers solve.
    assert len(run.solves) == plan_scenario(scenario, workers=2, window=4).solves
    # One worker solves one state after another; integrating may overlap solving.
    assert run.solving_s <= replay(run, 1) <= run.solving_s + run.integrate_s + 1e-9
    assert replay(run, 4) < replay(run, 2) < replay(run, 1)


def test_the_frontier_and_integration_bound_the_speed_up() -> None:
    # The first result opens four states; integrating costs 0.1 s a result.
    run = Trace(solves=[(0, 1.0)] + [(1, 1.0)] * 4, integrate_s=0.5, wall_s=0.0)
    # One worker: each solve waits for the last, integration overlaps the next solve.
    assert replay(run, 1) == pytest.approx(5.2)
    # The first state is alone whatever the number of workers; the four it opens
    # run side by side, and their results are integrated one after the other.
    assert replay(run, 4) == replay(run, 128) == pytest.approx(2.5)
    assert replay(run, 2, per_request_s=0.1) == pytest.approx(3.6)
