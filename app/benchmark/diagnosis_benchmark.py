"""No-plan benchmark: how fast `tandem plan` says why a scenario has no plan.

`python -m app.benchmark.diagnosis_benchmark [--runs K]` plans the paper's U6
bench (13 parts, geometric feasibility) with its dangerous foot5 moved to the
human-only region, where no arm reaches it, and prints the median wall time of
the whole command (start-up, geometric checks, diagnosis) with the check cache
cold and warm. Target: 2 s (the search alone runs for minutes).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from planner.plan.model import format_table
from planner.resources import scenario_path

TARGET_S = 2.0
FOOT5 = 'id = "foot5"\nkind = "foot"\nshape = "square"\nregion = "shared"\ndangerous = true\n'
FOOT5 += "pose = [0.76, 0.35, 0.0]"


def foot5_human_only() -> str:
    """paper-05 with foot5 where only the human reaches it."""
    text = scenario_path("paper/paper-05.toml").read_text()
    if FOOT5 not in text:
        raise SystemExit("paper-05 no longer places foot5 as this benchmark expects")
    moved = FOOT5.replace('"shared"', '"humanOnly"').replace("0.76", "1.2")
    return text.replace(FOOT5, moved).replace('name = "paper-05"', 'name = "foot5-human-only"')


def run_plan(path: Path, *extra: str) -> tuple[float, int, str]:
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "plan", str(path), "--quiet", *extra],
        capture_output=True,
        text=True,
        check=False,
    )
    return time.perf_counter() - t0, done.returncode, done.stderr.strip()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.diagnosis_benchmark")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "foot5-human-only.toml"
        path.write_text(foot5_human_only())
        cache = ["--cache-dir", str(Path(tmp) / "cache")]
        rows: list[tuple[str, ...]] = []
        line = ""
        for label, extra in (("cold (--no-cache)", ["--no-cache"]), ("warm cache", cache)):
            if extra is cache:
                run_plan(path, *cache)  # fill the cache once
            times = []
            for _ in range(args.runs):
                seconds, code, line = run_plan(path, *extra)
                if code != 1:
                    print(f"expected exit 1, got {code}: {line}", file=sys.stderr)
                    return 1
                times.append(seconds)
            median = statistics.median(times)
            verdict = "ok" if median <= TARGET_S else "over"
            rows.append((label, f"{median:.2f}", f"{max(times):.2f}", f"{TARGET_S:.1f}", verdict))
    print(format_table(("tandem plan, no plan", "median s", "max s", "target s", ""), rows))
    print(f"\n{line}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
