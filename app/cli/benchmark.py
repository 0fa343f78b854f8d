"""`tandem bench`: the paper's benchmark (`app.benchmark.planner_benchmark`) on the command line."""

from __future__ import annotations

import argparse
import json
import sys

from app.benchmark import planner_benchmark
from app.benchmark.planner_benchmark import BenchmarkRow
from app.cli.exit_codes import BadInput


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    parser.add_argument(
        "--only",
        nargs="+",
        action="extend",
        metavar="NAME",
        default=[],
        help="instances to run, e.g. paper-01 U07 (repeatable)",
    )
    parser.add_argument("--workers", type=int, default=0, help="worker processes (0: all cores)")
    parser.add_argument(
        "--no-families",
        action="store_true",
        help="only the paper's 15 instances, not the families continued to n=10",
    )
    parser.add_argument(
        "--families-to",
        type=int,
        default=10,
        metavar="N",
        help="continue the families U, P, R past the paper up to n=N (default 10)",
    )
    parser.add_argument(
        "--feasibility",
        choices=("geometry", "declared"),
        default="geometry",
        help="reachability from the motion planner, or from the layout's declared table",
    )
    parser.add_argument(
        "--repeat", type=int, default=1, metavar="K", help="plan each instance K times (median)"
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.repeat < 1 or args.workers < 0 or args.families_to < 2:
        raise BadInput(
            "tandem bench: --repeat must be >= 1, --workers >= 0 and --families-to >= 2"
        )
    try:
        selected = planner_benchmark.instances(
            args.only, families=not args.no_families, families_to=args.families_to
        )
    except KeyError as err:
        known = ", ".join(i.name for i in planner_benchmark.instances())
        raise BadInput(f"tandem bench: unknown instance {err.args[0]} (known: {known})") from err

    def progress(i: int, row: BenchmarkRow) -> None:
        # On stderr, so --json output stays parseable while a long run shows signs of life.
        done = f"{row.plan_s:.2f} s" if row.stats else "-"
        print(
            f"[{i + 1}/{len(selected)}] {row.instance.name}: {done}, {row.check}",
            file=sys.stderr,
            flush=True,
        )

    rows = planner_benchmark.run(
        selected,
        workers=args.workers,
        repeat=args.repeat,
        feasibility=args.feasibility,
        report=progress,
    )
    if args.json:
        print(json.dumps([r.as_dict() for r in rows], indent=1))
    else:
        print(planner_benchmark.report_text(rows, repeat=args.repeat, workers=args.workers))
    # Non-zero when any instance has no plan or an unsound one, so `make bench` notices.
    return 1 if any(r.error or r.violations for r in rows) else 0
