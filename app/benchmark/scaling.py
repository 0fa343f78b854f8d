"""Scaling on paper: measured with 1 and 2 Ray actors, replayed for 8 to 128 workers.

A plan depends on the window (states solved side by side per round), never on
the number of workers, so one process planning with the window that N workers
would use (2N) solves exactly the states N workers would, round by round. Its
trace (each solve's seconds, by round) is replayed: each round's requests go to
the least busy of N workers in request order, the round ends with its slowest
worker, and the coordinator then integrates the results alone. What limits the
speed-up shows in the table: rounds narrower than the number of workers (the
frontier), and the integration, which does not shrink with more workers.

    python -m app.benchmark.scaling [--only NAME...] [--no-ray]
"""

from __future__ import annotations

import argparse
import heapq
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

from app.benchmark import planner_benchmark
from planner.hcp import ConditionalPlanner
from planner.plan import format_table
from planner.planning import plan_scenario
from planner.scenario import Scenario

PREDICTED = (1, 2, 8, 32, 128)
DEFAULT_INSTANCES = ("paper-05", "U10")


@dataclass(frozen=True)
class Trace:
    rounds: list[list[float]]  # seconds of each solve, per round, in request order
    integrate_s: float
    wall_s: float

    @property
    def solves(self) -> int:
        return sum(len(r) for r in self.rounds)


def trace(scenario: Scenario, window: int) -> Trace:
    """Plans `scenario` in this process with `window` and records every solve."""
    planners: list[ConditionalPlanner] = []

    def keep(planner: ConditionalPlanner) -> None:
        # Solved as several workers would solve (each answer from its state alone),
        # so this one process plans exactly their DAG.
        planner.problem = replace(planner.problem, history_free=True)
        planners.append(planner)

    t0 = time.perf_counter()
    plan_scenario(scenario, workers=1, window=window, planner_hook=keep)
    wall = time.perf_counter() - t0
    planner = planners[0]
    rounds: dict[int, list[float]] = {}
    for number, seconds in planner.trace:
        rounds.setdefault(number, []).append(seconds)
    return Trace([rounds[k] for k in sorted(rounds)], planner.integrate_s, wall)


def replay(run: Trace, workers: int, per_request_s: float = 0.0) -> float:
    """Predicted seconds of `run`'s solving and integration on `workers` workers."""
    total = run.integrate_s
    for solves in run.rounds:
        # Least busy worker first (the first of them on a tie), as BranchActors does.
        busy = [(0.0, i) for i in range(workers)]
        for seconds in solves:
            load, i = heapq.heappop(busy)
            heapq.heappush(busy, (load + seconds + per_request_s, i))
        total += max(load for load, _ in busy)
    return total


def measure_ray(scenario: Scenario, actors: int) -> float:
    t0 = time.perf_counter()
    plan_scenario(scenario, workers=actors, cluster="auto", window=2 * actors)
    return time.perf_counter() - t0


def report(name: str, scenario: Scenario, use_ray: bool) -> str:
    base = trace(scenario, 2)
    lines = [f"{name}: {base.solves} solves, one process {base.wall_s:.2f} s "
             f"(solving {sum(map(sum, base.rounds)):.2f} s, integrating {base.integrate_s:.2f} s)"]
    overhead = 0.0
    if use_ray:
        ray1, ray2 = measure_ray(scenario, 1), measure_ray(scenario, 2)
        overhead = max(0.0, (ray1 - base.wall_s) / max(1, base.solves))
        lines.append(f"  measured with Ray: 1 actor {ray1:.2f} s, 2 actors {ray2:.2f} s "
                     f"({ray1 / ray2:.2f}x); {overhead * 1000:.2f} ms per request beyond solving")
    rows: list[tuple[str, ...]] = []
    for workers in PREDICTED:
        run = base if workers == 1 else trace(scenario, 2 * workers)
        one = replay(run, 1, overhead)
        predicted = replay(run, workers, overhead)
        narrow = sum(1 for r in run.rounds if len(r) < workers) / len(run.rounds)
        width = run.solves / len(run.rounds)
        rows.append((
            str(workers), str(2 * workers), str(run.solves), str(len(run.rounds)),
            f"{width:.1f}", f"{100 * narrow:.0f} %", f"{predicted:.2f}",
            f"{one / predicted:.2f}x", f"{100 * run.integrate_s / predicted:.0f} %",
        ))  # fmt: skip
    header = ("workers", "window", "solves", "rounds", "states/round", "rounds < workers",
              "predicted s", "speed-up", "integration")  # fmt: skip
    return "\n".join([*lines, format_table(header, rows)])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", default=list(DEFAULT_INSTANCES), metavar="NAME")
    parser.add_argument("--no-ray", action="store_true", help="replay only, measure nothing")
    args = parser.parse_args(argv)
    use_ray = not args.no_ray
    if use_ray:
        from planner import cluster

        try:
            cluster.connect("auto", num_cpus=2)
        except cluster.ClusterUnavailable as err:
            print(f"(no Ray measurement: {err})")
            use_ray = False
    print("Declared feasibility; speed-up = predicted 1 worker / predicted N workers.\n")
    for instance in planner_benchmark.instances(args.only):
        scenario = planner_benchmark.load(instance, feasibility="declared")
        print(report(instance.name, scenario, use_ray) + "\n", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
