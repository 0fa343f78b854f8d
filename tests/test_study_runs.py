"""A study's session sent back whole and stored by the study's process; the figure's
intervals and names."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from app.execution.events import HUMAN, ExecutionEvent
from app.sessions.store import SessionStore
from app.sessions.studies import finished, jobs, study_sessions
from app.sessions.study_figure import short_names, whisker
from app.sessions.study_runs import Plans, SessionRun, plan_hash, store_run
from tests.plan_fixtures import default_plan


def _run(result: str = "goal") -> SessionRun:
    """A robot's step from 0 s to 2 s and the human's action it asked for, from 1.5 s
    to 4 s: the session ends with the human, after the robot's last step."""
    plan = default_plan()
    node_id, node = next((i, n) for i, n in plan.nodes.items() if n.kind == "actuation")
    events = (
        ExecutionEvent(0, 2.0, node_id, node.action, "actuation", start=0.0, end=2.0),
        ExecutionEvent(1, 4.0, node_id, node.action, HUMAN, source="simulated",
                       text="attaches the part", start=1.5, end=4.0),
    )  # fmt: skip
    return SessionRun("s", "default/normal/normal/cooperative/clicks", 1, "seed 1", plan,
                      plan_hash(plan), (), events, result)  # type: ignore[arg-type]  # fmt: skip


def test_a_stored_run_ends_with_its_last_event_the_humans_included(tmp_path: Path) -> None:
    run = pickle.loads(pickle.dumps(_run()))  # as it comes back from a worker
    assert run.ended == 4.0
    with SessionStore(tmp_path) as store:
        session_id = store_run(store, run, Plans())
        record = store.get(session_id)
        events = store.events(session_id)
        tagged = finished(study_sessions(store.db, "s"))
    assert record.clock == "simulated" and record.result == "goal"
    assert record.ended == pytest.approx(record.started + 4.0)
    # The events keep their times, from the session's start.
    assert [e.kind for e in events] == ["actuation", HUMAN]
    times = [t - record.started for e in events for t in (e.start, e.end) if t is not None]
    assert times == pytest.approx([0.0, 2.0, 1.5, 4.0], abs=1e-6)
    assert events[1].source == "simulated" and events[1].text == "attaches the part"
    assert tagged[("default/normal/normal/cooperative/clicks", 1)].session_id == session_id


def test_a_plan_brought_by_many_runs_is_stored_once(tmp_path: Path) -> None:
    plans = Plans()
    with SessionStore(tmp_path) as store:
        first = store_run(store, _run(), plans)
        again = store_run(store, pickle.loads(pickle.dumps(_run())), plans)
        assert store.get(first).plan_hash == store.get(again).plan_hash == _run().plan_key
        assert store.db.execute("select count(*) from plans").fetchone()[0] == 1
        # A second run of one (condition, participant): the latest at a final result counts.
        assert finished(study_sessions(store.db, "s"))[(_run().condition, 1)].session_id == again


def test_the_figures_whiskers_stay_in_the_metrics_range() -> None:
    line = {"mean": 0.05, "ci95_low": -0.12, "ci95_high": 0.22}
    assert whisker("concurrent_share", line) == (0.0, 0.22)
    assert whisker("robot_idle_share", {"mean": 0.9, "ci95_low": 0.7, "ci95_high": 1.1}) == (
        0.7,
        1.0,
    )
    # A time is not negative and has no upper end.
    assert whisker("task_s", {"mean": 3.0, "ci95_low": -1.0, "ci95_high": 7.0}) == (0.0, 7.0)
    # One session: no interval, the mean alone.
    assert whisker("task_s", {"mean": 3.0, "ci95_low": None, "ci95_high": None}) == (3.0, 3.0)


def test_the_figure_names_conditions_by_what_varies() -> None:
    names, shared = short_names(["default/normal/normal/cooperative/clicks",
                                 "default/strict/normal/hesitant/clicks"])  # fmt: skip
    assert shared == "default/*/normal/*/clicks"
    assert list(names.values()) == ["normal/cooperative", "strict/hesitant"]
    assert short_names(["a/b", "c/d"]) == ({"a/b": "a/b", "c/d": "c/d"}, "")


def test_a_voice_participants_speech_is_timed_on_the_sessions_clock(tmp_path: Path) -> None:
    """A study's voice condition keeps the human's speech as human activity (source
    voice), on the session's simulated clock within each question's wait."""
    from app.sessions.metrics import session_metrics
    from app.sessions.studies import load_study
    from app.study.engine import run_job

    path = tmp_path / "v.toml"
    path.write_text(
        '[study]\nname = "v"\nparticipants = 1\nseed = 3\n[conditions]\n'
        'scenario = "default.toml"\nchannel = ["voice"]\n',
        encoding="utf-8",
    )
    job = jobs(load_study(path))[0]
    run = run_job(job)
    assert run.result == "goal"
    speech = [e for e in run.events if e.kind == HUMAN and e.source == "voice"]
    assert speech
    questions = [e for e in run.events if e.kind == "communication" and e.wait_start is not None]
    for said in speech:
        asked = next(q for q in questions if q.node == said.node)
        assert asked.wait_start <= said.start < said.end <= asked.end  # type: ignore[operator]
    metrics = session_metrics(run.events, "simulated")
    assert metrics.timed and metrics.human_active_s and metrics.human_active_s > 0
