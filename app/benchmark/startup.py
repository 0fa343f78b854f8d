"""How long `tandem` takes to start, and what each command loads.

`python -m app.benchmark.startup [--runs N]` runs each command N times (9 by
default), the commands in turn so that a busy machine slows them alike, and
prints one table: the median wall time of each, its ratio to `python -c pass`
(the interpreter's own start, which no command can beat, so the ratio compares
across machines where the seconds do not), its median processor time (about
its wall time on an idle machine, where a busy one stretches the wall time), the
goal where there is one, and the heavy packages the command imported (read from
`python -X importtime`).

`tandem --help` and `tandem sessions list` on an empty store must load none of
the solver, the physics engine, the motion planner, the dashboard or the
cluster; `tandem plan --help` loads the planner and shows what that costs.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from planner.resources import scenario_path

RUNS = 9
# The packages a light command must not import: clingo (the solver), pybullet
# (physics), ompl (motion planning), viser (the dashboard), ray (the cluster).
HEAVY = ("clingo", "pybullet", "ompl", "viser", "ray")
IMPORT_LINE = "import time:"


@dataclass(frozen=True)
class Command:
    label: str
    argv: tuple[str, ...]  # after the program: () is `python -c pass`
    goal_s: float | None = None  # the goal on a quiet 2-core machine


@dataclass(frozen=True)
class Timing:
    command: Command
    median_s: float
    ratio: float  # to `python -c pass`
    cpu_s: float  # median user + system time: about the wall time on an idle machine
    heavy: tuple[str, ...]


def tandem_program() -> list[str]:
    """The installed `tandem` script beside this interpreter, else `python -m app.cli`."""
    script = Path(sys.executable).with_name("tandem")
    return [str(script)] if script.exists() else [sys.executable, "-m", "app.cli"]


def commands(data_dir: Path) -> list[Command]:
    scenario = str(scenario_path("default.toml"))
    return [
        Command("python -c pass", ()),
        Command("tandem --help", ("--help",), 0.3),
        Command(
            "tandem sessions list (empty store)",
            ("sessions", "list", "--data-dir", str(data_dir)),
            0.5,
        ),
        Command("tandem scenario check default.toml", ("scenario", "check", scenario)),
        Command("tandem plan --help (loads the planner)", ("plan", "--help")),
    ]


def command_line(command: Command) -> list[str]:
    if not command.argv:
        return [sys.executable, "-c", "pass"]
    return [*tandem_program(), *command.argv]


def _children_cpu() -> float:
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def run_once(argv: Sequence[str]) -> tuple[float, float]:
    """The wall time and the processor time of one run."""
    cpu, start = _children_cpu(), time.perf_counter()
    subprocess.run(argv, capture_output=True, check=True)
    return time.perf_counter() - start, _children_cpu() - cpu


def imported(argv: Sequence[str]) -> set[str]:
    """The top-level packages a run of `tandem argv` imports: Python's import
    profile (`-X importtime`, asked through the environment so that the `tandem`
    script itself runs) reports every module imported, on stderr."""
    done = subprocess.run(
        [*tandem_program(), *argv],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPROFILEIMPORTTIME": "1"},
        check=False,
    )
    lines = done.stderr.splitlines()
    if done.returncode != 0:
        said = "\n".join(line for line in lines if not line.startswith(IMPORT_LINE))
        raise RuntimeError(f"tandem {' '.join(argv)} failed: {said}")
    profile = [line.removeprefix(IMPORT_LINE) for line in lines if line.startswith(IMPORT_LINE)]
    rows = (line.split("|") for line in profile)
    # "self [us] | cumulative | module", under a header row of the same shape.
    return {row[2].strip().split(".")[0] for row in rows if row[0].strip().isdigit()}


def measure(runs: int) -> list[Timing]:
    with tempfile.TemporaryDirectory() as data_dir:
        listed = commands(Path(data_dir))
        times: dict[Command, list[tuple[float, float]]] = {command: [] for command in listed}
        for command in listed:  # once untimed: the files read are cached alike
            run_once(command_line(command))
        for _ in range(runs):
            for command in listed:
                times[command].append(run_once(command_line(command)))
        base = statistics.median(wall for wall, _ in times[listed[0]])
        timings = []
        for command in listed:
            median = statistics.median(wall for wall, _ in times[command])
            cpu = statistics.median(cpu for _, cpu in times[command])
            heavy = imported(command.argv) & set(HEAVY) if command.argv else set()
            timings.append(Timing(command, median, median / base, cpu, tuple(sorted(heavy))))
    return timings


def table(timings: Sequence[Timing], runs: int) -> str:
    width = max(len(t.command.label) for t in timings)
    lines = [
        f"Start-up: median of {runs} runs, wall time ({os.cpu_count()} cores)",
        f"{'command':<{width}}  {'median s':>8}  {'× python':>8}  {'cpu s':>6}  "
        f"{'goal s':>6}  loads",
    ]
    for t in timings:
        goal = "-" if t.command.goal_s is None else f"≤ {t.command.goal_s:.1f}"
        heavy = ", ".join(t.heavy) or "-"
        lines.append(
            f"{t.command.label:<{width}}  {t.median_s:>8.3f}  {t.ratio:>8.1f}  "
            f"{t.cpu_s:>6.3f}  {goal:>6}  {heavy}"
        )
    lines.append(
        "cpu s: user + system time, about the wall time on an idle machine; "
        "the goals are for an idle 2-core machine."
    )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=RUNS, help=f"runs per command ({RUNS})")
    args = parser.parse_args(argv)
    print(table(measure(args.runs), args.runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
