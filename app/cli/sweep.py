"""`tandem sweep SCENARIO... --vary KEY=V1,V2`: plan every variant, audit, tabulate, plot."""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from app.benchmark.sweep_plot import plot_sweep
from app.cli.exit_codes import BadInput
from planner.plan.model import format_table
from planner.resources import find_scenario
from planner.sweep import ROW_KEYS, Variant, Variation, parse_variation, plan_variant, variants


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenarios", nargs="+", metavar="scenario", help="scenario files or names")
    parser.add_argument(
        "--vary",
        action="append",
        required=True,
        metavar="KEY=V1,V2",
        help="a setting and its values, e.g. safety=strict,normal or human.initiative=0,1",
    )
    parser.add_argument("-o", "--output", required=True, help="the CSV file, one row per variant")
    parser.add_argument("--plot", help="the PNG figure (default: the CSV's name with .png)")
    parser.add_argument(
        "--workers", type=int, default=0, help="local processes, one variant each (0: all cores)"
    )
    parser.add_argument(
        "--cluster",
        metavar="auto|ray://HOST:PORT",
        help="plan the variants as Ray tasks on this cluster instead of local processes",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    try:
        variations = [parse_variation(spec) for spec in args.vary]
        todo = _variants(args.scenarios, variations)
    except ValueError as err:
        raise BadInput(f"tandem sweep: {err}") from err
    out = Path(args.output)
    figure = Path(args.plot) if args.plot else out.with_suffix(".png")
    for folder in {out.parent, figure.parent}:
        folder.mkdir(parents=True, exist_ok=True)
    print(f"{len(todo)} variants of {len(args.scenarios)} scenario(s)", file=sys.stderr)
    rows = run_variants(todo, args.cluster, args.workers)
    columns = ["scenario", *(v.name for v in variations), *ROW_KEYS]
    with out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    plot_sweep(rows, variations, figure)
    shown = ["scenario", *(v.name for v in variations), "L", "D", "N", "plan_s", "violations"]
    print(format_table(tuple(shown), [tuple(_cell(r[c]) for c in shown) for r in rows]))
    print(f"wrote {out} and {figure}")
    # Non-zero when a variant has no plan or an unsound one.
    return 1 if any(r["error"] or r["violations"] for r in rows) else 0


def _variants(scenarios: list[str], variations: list[Variation]) -> list[Variant]:
    from planner.scenario.loading import load_scenario

    out = []
    for name in scenarios:
        path = find_scenario(name)
        scenario = load_scenario(path)  # a clear error for a bad file before any planning
        out += variants(scenario.name, path.read_text(encoding="utf-8"), variations)
    return out


def run_variants(todo: list[Variant], cluster: str | None, workers: int) -> list[dict[str, Any]]:
    """Plans every variant: as Ray tasks on `cluster`, else in `workers` local processes."""
    if cluster:
        from planner.search import cluster as ray_cluster

        ray_cluster.connect(cluster)
        return ray_cluster.map_tasks(plan_variant, todo)
    with ProcessPoolExecutor(
        max_workers=workers or mp.cpu_count(), mp_context=mp.get_context("fork")
    ) as pool:
        return list(pool.map(plan_variant, todo))


def _cell(value: object) -> str:
    return "-" if value is None else str(value)
