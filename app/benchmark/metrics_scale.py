"""`tandem sessions metrics --json` over a study's 10,000 timed sessions, from the shell.

`python -m app.benchmark.metrics_scale [--sessions N] [--runs R]` builds a store of
N sessions (10,000 by default) with `app.benchmark.store_scale`'s builder (copies
of real seeded executions on the simulated clock, the simulated human's actions
among their events, some answered by the simulated camera), then runs the
command line on it R times (3 by default) as a user would, process start-up
included, and prints one table: the sessions and events measured, and the median,
fastest and slowest wall time against the goal (3 s for 10,000 sessions).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from app.benchmark.store_scale import build_store, real_executions
from app.sessions.store import SessionStore
from planner.planning import plan_scenario
from planner.resources import scenario_path
from planner.scenario.loading import load_scenario

SESSIONS = 10_000
RUNS = 3
GOAL_S = 3.0  # for 10,000 sessions, start-up included


@dataclass(frozen=True)
class MetricsScaleReport:
    sessions: int
    events: int
    human_events: int
    timed: int  # sessions the command measured as timed
    with_human: int  # of them, those whose human was active
    runs_s: tuple[float, ...]  # each run's wall time, process start-up included

    @property
    def median_s(self) -> float:
        return statistics.median(self.runs_s)


def command(data_dir: Path) -> list[str]:
    return [sys.executable, "-m", "app.cli", "sessions", "metrics", "--json",
            "--data-dir", str(data_dir)]  # fmt: skip


def timed_runs(data_dir: Path, runs: int) -> tuple[tuple[float, ...], list[dict[str, object]]]:
    """Each run's wall time, and the rows the last one wrote."""
    times = []
    out = ""
    for _ in range(runs):
        begun = time.perf_counter()
        done = subprocess.run(command(data_dir), capture_output=True, text=True, check=True)
        times.append(time.perf_counter() - begun)
        out = done.stdout
    rows: list[dict[str, object]] = json.loads(out)
    return tuple(times), rows


def run(sessions: int, runs: int, data_dir: Path) -> MetricsScaleReport:
    scenario = load_scenario(scenario_path("default.toml"))
    plan = plan_scenario(scenario, workers=1).plan
    with SessionStore(data_dir) as store:
        events = build_store(store, real_executions(plan, scenario), plan, sessions)
        human = store.db.execute("select count(*) from events where kind = 'human'").fetchone()
    times, rows = timed_runs(data_dir, runs)
    timed = [r for r in rows if r["timed"]]
    active = [r for r in timed if isinstance(h := r["human_active_s"], float | int) and h > 0]
    return MetricsScaleReport(len(rows), events, human[0], len(timed), len(active), times)


def table(report: MetricsScaleReport) -> str:
    goal = GOAL_S * report.sessions / SESSIONS
    rows = [
        ("sessions", f"{report.sessions} ({report.timed} timed, {report.with_human} with "
                     "human activity)"),
        ("events", f"{report.events} ({report.human_events} of the human)"),
        ("median", f"{report.median_s:.2f} s (goal <= {goal:.1f} s)"),
        ("fastest", f"{min(report.runs_s):.2f} s"),
        ("slowest", f"{max(report.runs_s):.2f} s"),
    ]  # fmt: skip
    width = max(len(name) for name, _ in rows)
    lines = [
        f"tandem sessions metrics --json, process start-up included "
        f"(median of {len(report.runs_s)} runs)"
    ]
    lines += [f"  {name:<{width}}  {value}" for name, value in rows]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=SESSIONS, help="sessions to store")
    parser.add_argument("--runs", type=int, default=RUNS, help="runs of the command (>= 1)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="tandem-metrics-") as folder:
        report = run(args.sessions, max(1, args.runs), Path(folder))
    print(table(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
