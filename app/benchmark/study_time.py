"""How long a 60-session study takes: `python -m app.benchmark.study_time`.

Writes a study of 2 conditions (a cooperative and a hesitant human on the default
scenario, clicks answering) x 30 simulated participants into a temporary folder,
runs `tandem study` on it with a fresh session store (the plan is made once per
condition, then cached), and runs the same command again, which finds every
session done. The sessions run in worker processes (or, with `--cluster auto`,
as Ray tasks on a local cluster started for each run) and come back to the
study's process, which alone stores them. Prints one table: sessions, workers,
the wall time of the first run and per session, and the time of the second run
(resuming with nothing left, then writing the CSV, summary and figure again).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from planner.plan.model import format_table
from planner.resources import find_scenario

STUDY = """[study]
name = "bench"
participants = {participants}
seed = 1

[conditions]
scenario = "{scenario}"
behaviour = ["cooperative", "hesitant"]
channel = "clicks"
"""


def _run(study: Path, data: Path, out: Path, workers: int, cluster: str | None) -> float:
    began = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "app.cli", "study", str(study), "--data-dir", str(data),
         "--out", str(out), "--workers", str(workers),
         *(["--cluster", cluster] if cluster else [])],
        check=True, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    return time.perf_counter() - began


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=30, help="per condition (default 30)")
    parser.add_argument("--workers", type=int, default=0, help="processes (0: all cores)")
    parser.add_argument("--cluster", help="run the sessions as Ray tasks (auto: a local cluster)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="tandem-study-bench-") as tmp:
        folder = Path(tmp)
        study = folder / "bench.toml"
        scenario = find_scenario("default.toml").resolve().as_posix()
        study.write_text(STUDY.format(participants=args.participants, scenario=scenario))
        first = _run(study, folder / "data", folder / "out", args.workers, args.cluster)
        second = _run(study, folder / "data", folder / "out", args.workers, args.cluster)
        rows = (folder / "out" / "sessions.csv").read_text().count("\n") - 1
    sessions = 2 * args.participants
    print(f"\nA {sessions}-session study (2 conditions x {args.participants} participants, "
          "default.toml, clicks, simulated clock)")  # fmt: skip
    print(format_table(
        ("sessions", "CSV rows", "workers", "first run s", "s per session", "run again s"),
        [(str(sessions), str(rows), _workers(args.workers, args.cluster), f"{first:.1f}",
          f"{first / sessions:.2f}", f"{second:.1f}")],
    ))  # fmt: skip
    return 0 if rows == sessions else 1


def _workers(workers: int, cluster: str | None) -> str:
    return f"Ray {cluster}" if cluster else str(workers or mp.cpu_count())


if __name__ == "__main__":
    raise SystemExit(main())
