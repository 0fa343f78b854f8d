"""The session store at a study's scale: listing, filtering and reading 10,000 sessions.

`python -m app.benchmark.store_scale [--sessions N]` builds a store of N sessions
(10,000 by default) in a temporary folder and prints one table: how many sessions
and events it holds, how long it took to build, how long listing all of them and
filtering by scenario, result and start date take (the median of several), and
how long reading the events of 1,000 sessions takes (what the metrics over 1,000
sessions must read first).

The events are real: seeded executions of the default scenario's plan, most
answered at random and some by the simulated camera (whose evidence and JPEG
frames are stored as a camera session's are), each session a copy of one of them
moved to its own start time (its events' times with it, on the simulated clock,
the simulated human's actions among them), so the store has the rows, the
evidence, the times and the event counts of real runs. Rows are written in one
transaction (a commit per event, as a live session does, would take minutes at
this scale), with the store's own plan hashing and event rows.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from app.execution.events import Clock, ExecutionEvent, Result
from app.execution.walker import Executor
from app.responses.camera import camera_responses
from app.sessions.export import event_row
from app.sessions.store import EVENT_TIMES, SessionStore
from app.sources.outcomes import FallbackSource, RandomSource
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.resources import scenario_path
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario

SESSIONS = 10_000
READ_SESSIONS = 1_000  # the sessions whose events are read, as the metrics would
REPEATS = 7  # each listing is timed this often; the median is reported
TEMPLATES = 20  # distinct random executions copied into the store
CAMERA_TEMPLATES = 4  # and executions answered by the simulated camera
SPAN_DAYS = 120  # the sessions' start times spread over this many days
SINCE_DAYS = 7  # the `since` filter: the last week's sessions
# Ten scenarios a study might run, and results in the proportions of a real one:
# most reach the goal.
SCENARIOS = tuple(f"study-{i:02d}" for i in range(10))
RESULT_WEIGHTS: dict[Result, float] = {
    "goal": 0.85,
    "aborted": 0.05,
    "interrupted": 0.05,
    "dead-end": 0.05,
}
# The template runs are on the simulated clock (the executor's default), with the
# simulated human's own actions as `human` events: timed sessions.
CLOCK: Clock = "simulated"
SESSION_COLUMNS = (
    "scenario",
    "scenario_sha256",
    "plan_hash",
    "started",
    "ended",
    "result",
    "note",
    "pid",
    "host_boot",
    "clock",
)


@dataclass(frozen=True)
class ScaleReport:
    sessions: int
    events: int
    build_s: float
    list_all_ms: float
    by_scenario_ms: float
    by_result_ms: float
    since_ms: float
    read_sessions: int  # sessions whose events were read (READ_SESSIONS, or all if fewer)
    read_events_s: float
    listed: dict[str, int]  # how many sessions each listing returned


def real_executions(plan: Plan, scenario: Scenario) -> list[list[ExecutionEvent]]:
    """The events of seeded random executions of `plan`, then of executions whose
    sensing the simulated camera answers (the rest at random, as `tandem execute`)."""
    runs = []
    for seed in range(TEMPLATES):
        executor = Executor(plan, RandomSource(seed))
        executor.run()
        runs.append(executor.events)
    for seed in range(CAMERA_TEMPLATES):
        camera = camera_responses("sim", scenario, plan, seed)
        source = FallbackSource(camera.source, RandomSource(seed))
        executor = Executor(plan, source, camera.listeners)
        executor.run()
        camera.close()
        runs.append(executor.events)
    return runs


def build_store(
    store: SessionStore,
    runs: Sequence[Sequence[ExecutionEvent]],
    plan: Plan,
    sessions: int,
    *,
    seed: int = 0,
    now: float | None = None,
) -> int:
    """Fills `store` with `sessions` sessions of `plan`, each a copy of one of `runs`
    (real executions); the number of events written."""
    rng = random.Random(seed)
    now = time.time() if now is None else now
    first = now - SPAN_DAYS * 86400
    starts = sorted(rng.uniform(first, now) for _ in range(sessions))
    digest = store.add_plan(plan)
    results = list(RESULT_WEIGHTS)
    weights = list(RESULT_WEIGHTS.values())
    written = 0
    conn = store.db.conn
    marks = ", ".join("?" * len(SESSION_COLUMNS))
    insert_session = f"insert into sessions ({', '.join(SESSION_COLUMNS)}) values ({marks})"
    with conn:  # one transaction
        for started in starts:
            run = runs[rng.randrange(len(runs))]
            scenario = rng.choice(SCENARIOS)
            result = rng.choices(results, weights)[0]
            shift = started - run[0].time
            ended = run[-1].time + shift + 1.0
            row = (scenario, "0" * 64, digest, started, ended, result, None, 1, "bench", CLOCK)
            session_id = conn.execute(insert_session, row).lastrowid
            written += _write_events(store, session_id, run, shift)
    return written


def _write_events(
    store: SessionStore, session_id: int | None, run: Sequence[ExecutionEvent], shift: float
) -> int:
    rows = []
    evidence = []
    for event in run:
        row = {"session_id": session_id, **event_row(event), **_times(event, shift)}
        row["time"] = event.time + shift
        rows.append(tuple(row.values()))
        if event.evidence is not None:
            detail = json.dumps(event.evidence.to_json(), sort_keys=True)
            evidence.append((session_id, event.seq, detail, event.evidence.jpeg))
    names = ", ".join(["session_id", *event_row(run[0]), *EVENT_TIMES])
    store.db.conn.executemany(
        f"insert into events ({names}) values ({', '.join('?' * len(rows[0]))})", rows
    )
    store.db.conn.executemany(
        "insert into evidence (session_id, seq, detail, jpeg) values (?, ?, ?, ?)", evidence
    )
    return len(rows)


def _times(event: ExecutionEvent, shift: float) -> dict[str, float | None]:
    """The event's start, end and wait, moved by `shift` (as the store's columns)."""
    times = (event.start, event.end, event.wait_start)
    return {
        column: None if t is None else t + shift
        for column, t in zip(EVENT_TIMES, times, strict=True)
    }


def median_ms(call: Callable[[], object], repeats: int = REPEATS) -> float:
    times = []
    for _ in range(repeats):
        begun = time.perf_counter()
        call()
        times.append(time.perf_counter() - begun)
    return statistics.median(times) * 1000


def measure(store: SessionStore, build_s: float, events: int, *, now: float) -> ScaleReport:
    """Times the listings and the reading of events on a built store."""
    since = now - SINCE_DAYS * 86400
    listings: dict[str, Callable[[], list[object]]] = {
        "all": lambda: list(store.list_sessions()),
        "scenario": lambda: list(store.list_sessions(scenario=SCENARIOS[0])),
        "result": lambda: list(store.list_sessions(result="aborted")),
        "since": lambda: list(store.list_sessions(since=since)),
    }
    listed = {name: len(call()) for name, call in listings.items()}
    times = {name: median_ms(call) for name, call in listings.items()}
    ids = [s.id for s in store.list_sessions()]
    chosen = random.Random(1).sample(ids, min(READ_SESSIONS, len(ids)))
    begun = time.perf_counter()
    for session_id in chosen:
        store.events(session_id)
    read_s = time.perf_counter() - begun
    return ScaleReport(
        sessions=len(ids),
        events=events,
        build_s=build_s,
        list_all_ms=times["all"],
        by_scenario_ms=times["scenario"],
        by_result_ms=times["result"],
        since_ms=times["since"],
        read_sessions=len(chosen),
        read_events_s=read_s,
        listed=listed,
    )


def run(sessions: int, data_dir: Path) -> ScaleReport:
    scenario = load_scenario(scenario_path("default.toml"))
    plan = plan_scenario(scenario, workers=1).plan
    runs = real_executions(plan, scenario)
    now = time.time()
    with SessionStore(data_dir) as store:
        begun = time.perf_counter()
        events = build_store(store, runs, plan, sessions, now=now)
        build_s = time.perf_counter() - begun
    # Measured on a store opened afresh, as `tandem sessions list` opens it.
    with SessionStore(data_dir) as store:
        return measure(store, build_s, events, now=now)


def table(report: ScaleReport) -> str:
    rows = [
        ("sessions", f"{report.sessions}"),
        ("events", f"{report.events}"),
        ("build", f"{report.build_s:.1f} s"),
        ("list all", f"{report.list_all_ms:.1f} ms ({report.listed['all']})"),
        (
            "list by scenario",
            f"{report.by_scenario_ms:.1f} ms ({report.listed['scenario']})",
        ),
        ("list by result", f"{report.by_result_ms:.1f} ms ({report.listed['result']})"),
        (
            f"list since {SINCE_DAYS} days ago",
            f"{report.since_ms:.1f} ms ({report.listed['since']})",
        ),
        (f"events of {report.read_sessions} sessions", f"{report.read_events_s:.2f} s"),
    ]
    width = max(len(name) for name, _ in rows)
    lines = [
        f"session store at scale (listings: median of {REPEATS}; sessions returned in brackets)"
    ]
    lines += [f"  {name:<{width}}  {value}" for name, value in rows]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=SESSIONS, help="sessions to store")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="tandem-store-") as folder:
        report = run(args.sessions, Path(folder))
    print(table(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
