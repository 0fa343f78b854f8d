"""`tandem study STUDY.toml`: simulated participants over conditions, resumable.

Each (condition, participant) is one headless session on a simulated timeline,
run in local processes (or as Ray tasks with `--cluster`) by the study engine
(app.study.engine), stored by this process alone. Run again after an
interruption, the command skips what ended at a final result and runs the rest
again. It then writes `sessions.csv`, `summary.csv` and `summary.png` into
`--out` (app.study.results).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from app.cli.exit_codes import BadInput
from app.sessions.store import SessionStore
from app.sessions.studies import (
    Study,
    StudyError,
    ensure_table,
    finished,
    jobs,
    load_study,
    study_sessions,
)
from app.study.engine import Abandoned, run_jobs
from app.study.results import write_results


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", metavar="STUDY.toml", help="the study file (docs/study.md)")
    parser.add_argument(
        "--out", help="folder for sessions.csv, summary.csv and summary.png "
        "(default: a folder named after the study, next to the study file)",
    )  # fmt: skip
    parser.add_argument("--data-dir", help="session store folder (default: $TANDEM_DATA_DIR, ...)")
    parser.add_argument(
        "--workers", type=int, default=0, help="local processes, one session each (0: all cores)"
    )
    parser.add_argument(
        "--cluster",
        metavar="auto|ray://HOST:PORT",
        help="run the sessions as Ray tasks on this cluster (they send their sessions back: "
        "only this machine needs --data-dir)",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    try:
        study = load_study(args.study)
    except StudyError as err:
        raise BadInput(str(err)) from err
    if args.workers < 0:
        raise BadInput(f"--workers {args.workers}: must be 0 or more")
    _check_scenarios(study)
    out = Path(args.out) if args.out else study.path.parent / study.name
    # The only writer of the store: the sessions run elsewhere come back here.
    with SessionStore(args.data_dir) as store:
        ensure_table(store.db)
        done = finished(study_sessions(store.db, study.name))
        todo = [j for j in jobs(study) if (j.condition.name, j.participant) not in done]
        total = len(study.conditions) * study.participants
        print(f"study {study.name}: {len(study.conditions)} conditions x "
              f"{study.participants} participants; {total - len(todo)} done, "
              f"{len(todo)} to run", file=sys.stderr)  # fmt: skip
        try:
            run_jobs(todo, store, args.cluster, args.workers)
            rows = write_results(study, store, out)
        except KeyboardInterrupt as stop:
            print("interrupted: run the same command again to go on", file=sys.stderr)
            if isinstance(stop, Abandoned):
                store.close()  # every stored session is committed; then end at once
                sys.stderr.flush()
                os._exit(130)
            return 130
    print(f"{len(rows)} sessions; wrote {out / 'sessions.csv'}, {out / 'summary.csv'} "
          f"and {out / 'summary.png'}")  # fmt: skip
    return 0 if len(rows) == total else 1


def _check_scenarios(study: Study) -> None:
    """Each scenario file read once, so a bad one is said before any session runs."""
    from planner.scenario.loading import load_scenario

    for path in {c.scenario for c in study.conditions}:
        load_scenario(path)
