"""`tandem plan SCENARIO`: plan every contingency, print the statistics table."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from planner.plan.model import TABLE_HEADER, format_table, stats_row
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from planner.search.hcp import Progress


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "input",
        metavar="scenario",
        help="scenario file (TOML), or a shipped one: default.toml, paper/U10.toml",
    )
    parser.add_argument("-o", "--output", help="write the tandem-plan/1 JSON here")
    parser.add_argument("--dot", help="write the plan tree as Graphviz DOT here")
    parser.add_argument("--workers", type=int, default=0, help="worker processes (0: all cores)")
    parser.add_argument(
        "--first-branch", action="store_true", help="print the branch the robot expects"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress line")
    parser.add_argument(
        "--cache-dir",
        help="where geometric checks are cached (default: $TANDEM_CACHE_DIR or ~/.cache/tandem)",
    )
    parser.add_argument(
        "--no-cache", action="store_true", help="check geometry afresh and store nothing"
    )
    parser.add_argument(
        "--cluster",
        metavar="auto|ray://HOST:PORT",
        help="solve branches on Ray actors (auto: this machine's cluster, or a local one); "
        "--workers actors (0: one per cluster CPU). Needs tandem[cluster]",
    )
    parser.add_argument(
        "--window",
        type=int,
        default=0,
        help="how many states may be solving at once (0: two per worker, four on benches with "
        "20 or more goal attachments); the plan depends "
        "on it, not on the number of workers",
    )
    parser.set_defaults(run=run)


def _progress_line(p: Progress) -> None:
    total = p.done + p.open
    width = 30
    filled = int(width * p.done / total) if total else width
    bar = "#" * filled + "." * (width - filled)
    print(
        f"\r[{bar}] {p.done} nodes planned, {p.open} open, {p.elapsed_s:.1f} s",
        end="",
        file=sys.stderr,
        flush=True,
    )


def run(args: argparse.Namespace) -> int:
    scenario = load_scenario(find_scenario(args.input))
    progress = None if args.quiet or not sys.stderr.isatty() else _progress_line
    try:
        cache_dir = ":memory:" if args.no_cache else args.cache_dir
        result = plan_scenario(
            scenario,
            workers=args.workers,
            progress=progress,
            cache_dir=cache_dir,
            cluster=args.cluster,
            window=args.window,
        )
    finally:
        if progress:
            # End the progress line, also when a dead end escapes to main.
            print(file=sys.stderr)
    plan = result.plan
    if args.output:
        plan.write(args.output)
    if args.dot:
        Path(args.dot).write_text(plan.dot())
    print(
        f"{scenario.name}: plan with {plan.statistics['dag_nodes']} distinct nodes "
        f"(first branch after {result.first_branch_s:.2f} s)"
    )
    print(format_table(TABLE_HEADER, [stats_row(scenario.name, plan.statistics)]))
    if args.first_branch:
        print("\nFirst branch (the outcomes the robot hopes for):")
        for i, (action, outcome) in enumerate(plan.first_branch(), 1):
            print(f"  {i:2d}. {action}" + (f"  -> {outcome}" if outcome is not None else ""))
    return 0
