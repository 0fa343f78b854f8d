"""The session store at a study's scale, checked without a stopwatch.

A store of 2,000 sessions copied from real executions (the benchmark's builder,
`app.benchmark.store_scale`, which times 10,000) lists and filters exactly the
sessions a plain filter over all of them finds, and every listing SQLite runs
walks an index instead of reading the whole table or sorting it; an old store
gets the indexes when it is opened. The measures read from the rows of all its
sessions at once (`app.sessions.stored_metrics`, what `tandem sessions metrics`
runs, timed by `app.benchmark.metrics_scale`) are those of `session_metrics` on
each session's whole events.
"""

from __future__ import annotations

import shutil
import sqlite3
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from app.benchmark import metrics_scale
from app.benchmark.store_scale import SCENARIOS, build_store, main, real_executions
from app.sessions.database import INDEXES
from app.sessions.metrics import session_metrics
from app.sessions.store import SessionRecord, SessionStore
from app.sessions.stored_metrics import stored_metrics
from planner.resources import scenario_path
from planner.scenario.loading import load_scenario
from tests.plan_fixtures import default_plan

SESSIONS = 2_000
NOW = time.time()
FIXTURE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> SessionStore:
    folder = tmp_path_factory.mktemp("scale")
    plan = default_plan()
    runs = real_executions(plan, load_scenario(scenario_path("default.toml")))
    assert any(e.evidence is not None and e.evidence.jpeg for run in runs for e in run)
    with SessionStore(folder) as building:
        events = build_store(building, runs, plan, SESSIONS, seed=3, now=NOW)
    assert events > 10 * SESSIONS
    return SessionStore(folder)


@pytest.fixture(scope="module")
def everything(store: SessionStore) -> list[SessionRecord]:
    return store.list_sessions()


def test_listing_all_is_in_start_order_with_event_counts(
    store: SessionStore, everything: list[SessionRecord]
) -> None:
    assert len(everything) == SESSIONS
    assert [(s.started, s.id) for s in everything] == sorted((s.started, s.id) for s in everything)
    total = store.db.execute("select count(*) from events").fetchone()[0]
    assert sum(s.events for s in everything) == total
    pictures = store.db.execute("select count(*) from evidence where jpeg is not null")
    assert pictures.fetchone()[0] > 0  # camera sessions keep their frames
    for record in everything[:: SESSIONS // 20]:
        assert record.events == len(store.events(record.id)) > 0
        assert store.get(record.id) == record


def test_filters_find_what_a_plain_filter_finds(
    store: SessionStore, everything: list[SessionRecord]
) -> None:
    week_ago = NOW - 7 * 86400
    for scenario in SCENARIOS[:3]:
        found = store.list_sessions(scenario=scenario)
        assert found == [s for s in everything if s.scenario == scenario] != []
    for result in ("goal", "aborted", "dead-end"):
        found = store.list_sessions(result=result)
        assert found == [s for s in everything if s.result == result] != []
    assert store.list_sessions(result="running") == []
    recent = store.list_sessions(since=week_ago)
    assert recent == [s for s in everything if s.started >= week_ago] != []
    both = store.list_sessions(scenario=SCENARIOS[1], result="goal", since=week_ago)
    assert both == [s for s in recent if s.scenario == SCENARIOS[1] and s.result == "goal"]


def query_plans(store: SessionStore) -> dict[str, list[str]]:
    """What SQLite does for each listing: the steps of the plan of each statement
    `list_sessions` runs (bound values inlined by the trace)."""
    statements: list[str] = []
    store.db.conn.set_trace_callback(statements.append)
    try:
        listings: dict[str, Callable[[], list[SessionRecord]]] = {
            "all": lambda: store.list_sessions(),
            "scenario": lambda: store.list_sessions(scenario=SCENARIOS[0]),
            "result": lambda: store.list_sessions(result="aborted"),
            "since": lambda: store.list_sessions(since=NOW - 86400),
            "running": lambda: store.list_sessions(result="running"),
        }
        sql = {}
        for name, listing in listings.items():
            statements.clear()
            listing()
            sql[name] = next(s for s in statements if s.lstrip().startswith("select"))
    finally:
        store.db.conn.set_trace_callback(None)
    return {
        name: [row[3] for row in store.db.execute(f"explain query plan {text}").fetchall()]
        for name, text in sql.items()
    }


def test_every_listing_walks_an_index(store: SessionStore) -> None:
    for name, steps in query_plans(store).items():
        assert steps, name
        for step in steps:
            # A table is only ever read along an index, and nothing is sorted afresh.
            if step.startswith(("SCAN", "SEARCH")):
                assert " USING " in step and "INDEX" in step, (name, step)
            assert "TEMP B-TREE" not in step, (name, step)
        if name != "all":
            assert steps[0].startswith("SEARCH s USING INDEX"), (name, steps)


def test_an_old_store_gets_the_indexes(tmp_path: Path) -> None:
    shutil.copy(FIXTURE, tmp_path / "sessions.db")

    def indexes() -> set[str]:
        with sqlite3.connect(tmp_path / "sessions.db") as conn:
            rows = conn.execute("select name from sqlite_master where type = 'index'")
            return {name for (name,) in rows}

    wanted = {f"idx_{table}_{'_'.join(columns)}" for table, columns in INDEXES}
    assert not wanted & indexes()
    with SessionStore(tmp_path) as store:
        sessions = store.list_sessions()
        assert len(sessions) == 4
        assert store.list_sessions(result="goal") == sessions
    assert wanted <= indexes()


def test_the_benchmark_prints_its_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--sessions", "300"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("session store at scale")
    assert any(line.split()[:2] == ["sessions", "300"] for line in lines)
    for label in ("list all", "list by scenario", "list by result", "events of 300 sessions"):
        assert any(line.strip().startswith(label) for line in lines), label


def test_metrics_read_from_the_rows_are_those_of_the_whole_events(
    store: SessionStore, everything: list[SessionRecord]
) -> None:
    lean = stored_metrics(store, everything)
    whole = [session_metrics(store.events(s.id), s.clock) for s in everything]
    assert lean == whole
    # The store is what a study measures: timed sessions on the simulated clock with
    # the simulated human's actions, and camera answers judged against the truth.
    assert all(s.clock == "simulated" for s in everything)
    assert all(m.timed and m.human_active_s for m in whole)
    assert sum(m.camera_answers for m in whole) > 0
    assert any(m.camera_agreement is not None for m in whole)
    assert any(m.robot_idle_s and m.functional_delay_s for m in whole)
    some = everything[::7]
    assert stored_metrics(store, some) == [whole[k] for k in range(0, SESSIONS, 7)]
    assert stored_metrics(store, []) == []


def test_the_metrics_benchmark_prints_its_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert metrics_scale.main(["--sessions", "200", "--runs", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("tandem sessions metrics --json")
    sessions = next(line.split(None, 1)[1] for line in lines if line.split()[0] == "sessions")
    assert sessions == "200 (200 timed, 200 with human activity)"
    assert any(line.strip().startswith("median") for line in lines)
