"""Scaling on paper: measured with 1 and 2 Ray actors, replayed for 8 to 128 workers.

A plan depends on the window (how many solves may be pending at once), never on
the number of workers, so one process planning with the window that N workers
would use (2N) solves exactly the states N workers would, in the same order. Its
trace (each solve's seconds, and how many results had been integrated when it
was asked) is replayed: the coordinator asks each state once that many results
are integrated, free workers take asked states in order, and results are
integrated in the order asked, each at the coordinator's measured cost. What
limits the speed-up shows in the table: how busy the workers are (the frontier:
a state is asked only once the result that opens it is integrated), and the
integration, which does not shrink with more workers.

    python -m app.benchmark.scaling [--only NAME...] [--no-ray]
"""

from __future__ import annotations

import argparse
import heapq
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

from app.benchmark import planner_benchmark
from planner.plan.model import format_table
from planner.planning import plan_scenario
from planner.scenario.loading import Scenario
from planner.search.hcp import ConditionalPlanner

PREDICTED = (1, 2, 8, 32, 128)
DEFAULT_INSTANCES = ("paper-05", "U10")


@dataclass(frozen=True)
class Trace:
    # Each solve in the order asked: how many solved results had been integrated
    # when it was asked, and its seconds.
    solves: list[tuple[int, float]]
    integrate_s: float
    wall_s: float

    @property
    def solving_s(self) -> float:
        return sum(seconds for _, seconds in self.solves)

    def pending(self, k: int) -> int:
        """Solves asked and not yet integrated once k of them were integrated."""
        return sum(1 for j, (after, _) in enumerate(self.solves) if after <= k <= j)


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
    return Trace(list(planner.trace), planner.integrate_s, wall)


def replay(run: Trace, workers: int, per_request_s: float = 0.0) -> float:
    """Predicted seconds of `run`'s solving and integration on `workers` workers."""
    per_result = run.integrate_s / max(1, len(run.solves))
    # When the first k results were integrated, for every k.
    integrated = [0.0]
    # The least busy worker first (the first of them on a tie), as BranchActors does;
    # asked states are taken in order.
    free = [(0.0, i) for i in range(workers)]
    for after, seconds in run.solves:
        # A state is asked after its opener's result (after <= its own index).
        at, i = heapq.heappop(free)
        end = max(at, integrated[after]) + seconds + per_request_s
        heapq.heappush(free, (end, i))
        integrated.append(max(end, integrated[-1]) + per_result)
    return integrated[-1]


def measure_ray(scenario: Scenario, actors: int) -> float:
    t0 = time.perf_counter()
    plan_scenario(scenario, workers=actors, cluster="auto", window=2 * actors)
    return time.perf_counter() - t0


def report(name: str, scenario: Scenario, use_ray: bool) -> str:
    base = trace(scenario, 2)
    lines = [f"{name}: {len(base.solves)} solves, one process {base.wall_s:.2f} s "
             f"(solving {base.solving_s:.2f} s, integrating {base.integrate_s:.2f} s)"]
    overhead = 0.0
    if use_ray:
        ray1, ray2 = measure_ray(scenario, 1), measure_ray(scenario, 2)
        overhead = max(0.0, (ray1 - base.wall_s) / max(1, len(base.solves)))
        lines.append(f"  measured with Ray: 1 actor {ray1:.2f} s, 2 actors {ray2:.2f} s "
                     f"({ray1 / ray2:.2f}x); {overhead * 1000:.2f} ms per request beyond solving")
    rows: list[tuple[str, ...]] = []
    for workers in PREDICTED:
        run = base if workers == 1 else trace(scenario, 2 * workers)
        one = replay(run, 1, overhead)
        predicted = replay(run, workers, overhead)
        busy = (run.solving_s + overhead * len(run.solves)) / (workers * predicted)
        rows.append((
            str(workers), str(2 * workers), str(len(run.solves)), f"{predicted:.2f}",
            f"{one / predicted:.2f}x", f"{100 * busy:.0f} %",
            f"{100 * run.integrate_s / predicted:.0f} %",
        ))  # fmt: skip
    header = ("workers", "window", "solves", "predicted s", "speed-up", "workers busy",
              "integration")  # fmt: skip
    return "\n".join([*lines, format_table(header, rows)])


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", default=list(DEFAULT_INSTANCES), metavar="NAME")
    parser.add_argument("--no-ray", action="store_true", help="replay only, measure nothing")
    args = parser.parse_args(argv)
    use_ray = not args.no_ray
    if use_ray:
        from planner.search import cluster

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
