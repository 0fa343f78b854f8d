"""A session's measures: Hoffman's fluency metrics, questions, repairs, agreement.

Each measure is checked on a hand-built session whose values are worked out
below (tests/test_hoffman_metrics.py has another); a stored session of the old
format gives counts and no times; the CLI writes them as CSV and JSON, says in
one line when a study is unknown, and leaves out a study's interrupted and
unfinished sessions, saying how many.
"""

from __future__ import annotations

import csv
import io
import json
import shutil
import subprocess
from pathlib import Path

import pytest

from app.execution.events import HUMAN, EventKind, ExecutionEvent
from app.execution.evidence import Evidence, Truth
from app.execution.timing import SimulatedTimeline
from app.execution.walker import Executor
from app.sessions.metrics import METRIC_KEYS, session_metrics
from app.sessions.store import SessionStore
from app.sessions.stored_metrics import stored_metrics
from app.sessions.studies import ensure_table, tag
from app.sources.outcomes import RandomSource
from planner.vocabulary import (
    AskHelp,
    Attach,
    Greet,
    Hold,
    RequestToAttach,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
)
from tests.plan_fixtures import ROOT, default_plan, tandem_command

OLD_STORE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"


def event(
    seq: int,
    kind: EventKind,
    start: float,
    end: float,
    action: object = None,
    *,
    outcome: str | None = None,
    source: str | None = None,
    truth: str | None = None,
    node: str | None = None,
) -> ExecutionEvent:
    """An event at node `n<seq>` (a human's at its request's `node`)."""
    return ExecutionEvent(
        seq, end, node or f"n{seq}", action, kind, outcome=outcome, source=source,  # type: ignore[arg-type]
        evidence=None if truth is None else Evidence(truth=Truth(truth)), start=start, end=end,
    )  # fmt: skip


# Robot: greet 0-2, request 2-4, hold 4-7, (waits) sense 13-14, askHelp 14-18, repair at
# 18, sense 25-26 (it waits again), attach 26-28 (a camera answer and a voice
# answer in between), then the goal at 28. Human: attaches 5-13 (reacting 1 s after
# the request, while the robot holds leg2), then 19-25 (1 s after saying yes).
HAND_BUILT = [
    event(0, "communication", 0, 2, Greet()),
    event(1, "communication", 2, 4, RequestToAttach("leg1", "top")),
    event(2, HUMAN, 5, 13, RequestToAttach("leg1", "top"), node="n1"),
    event(3, "actuation", 4, 7, Hold("left", "leg2")),
    event(4, "sensing", 13, 14, SenseHumanAttachingWhere("leg1", "top"), outcome="c1",
          source="camera", truth="c1"),
    event(5, "communication", 14, 18, AskHelp("leg3", "top"), outcome="yes", source="voice",
          truth="yes"),
    event(6, HUMAN, 19, 25, AskHelp("leg3", "top"), node="n5"),
    event(7, "repair", 18, 18),
    event(8, "fell-back", 18, 18),
    event(9, "sensing", 25, 26, SenseHumanHolding(), outcome="no", source="camera",
          truth="yes"),
    event(10, "actuation", 26, 28, Attach("left", "top", "c2")),
    event(11, "goal", 28, 28),
]  # fmt: skip


def test_each_measure_of_a_hand_built_session() -> None:
    m = session_metrics(HAND_BUILT, "simulated")
    assert m.timed and m.events == 12 and m.steps == 9  # not the human's nor the dialogue's
    assert m.task_s == 28
    # Robot active: 0-7, 13-18, 25-28 = 7 + 5 + 3.
    assert m.robot_active_s == 15 and m.robot_idle_s == 13
    # Human active: 5-13 and 19-25.
    assert m.human_active_s == 14 and m.human_idle_s == 14
    # Both active: 5-7 (the robot holds leg2 while the human attaches leg1).
    assert m.concurrent_s == 2
    # Nobody acted 18-19, from the robot's askHelp ending to the human starting: 1 s.
    # The human's 1 s before starting on the request (4-5) is no delay: the robot
    # was holding leg2 then. The robot started right as the human ended (13, 25).
    assert m.functional_delay_s == 1
    assert m.robot_idle_share == pytest.approx(13 / 28)
    assert m.human_idle_share == pytest.approx(14 / 28)
    assert m.concurrent_share == pytest.approx(2 / 28)
    assert m.functional_delay_share == pytest.approx(1 / 28)
    assert (m.askHelp, m.offerHelp, m.confirmAttach, m.requests) == (1, 0, 0, 1)
    assert m.askHelp_answer_s == 4  # asked at 14, answered at 18
    assert m.requests_answer_s == 1  # the human started 1 s after the request
    assert m.offerHelp_answer_s is None and m.confirmAttach_answer_s is None
    assert m.repairs == 1 and m.fallbacks == 1
    assert m.camera_answers == 2 and m.camera_agreement == 0.5
    assert m.voice_answers == 1 and m.voice_agreement == 1.0


def test_functional_delay_counts_the_robot_waiting_too() -> None:
    # The human attaches 0-5; the robot, idle since 1, starts sensing at 7: 2 s late.
    session = [
        event(0, "communication", 0, 1, RequestToAttach("leg1", "top")),
        event(1, HUMAN, 1, 5, RequestToAttach("leg1", "top"), node="n0"),
        event(2, "sensing", 7, 8, SenseHumanAttachingWhere("leg1", "top"), outcome="c1"),
    ]
    m = session_metrics(session, "wall")
    assert m.functional_delay_s == 2 and m.task_s == 8
    assert m.robot_active_s == 2 and m.human_active_s == 4 and m.concurrent_s == 0


def test_the_row_is_flat_stable_and_csv_ready() -> None:
    row = session_metrics(HAND_BUILT, "simulated").row()
    assert tuple(row) == METRIC_KEYS
    assert METRIC_KEYS[:4] == ("timed", "events", "steps", "task_s")
    assert all(isinstance(v, bool | int | float | str | type(None)) for v in row.values())
    out = io.StringIO()
    csv.DictWriter(out, METRIC_KEYS).writerows([row])
    assert out.getvalue().count(",") == len(METRIC_KEYS) - 1
    with pytest.raises(AttributeError):
        session_metrics(HAND_BUILT, "simulated").task_s = 1.0  # type: ignore[misc]


def test_an_old_session_gives_counts_and_no_times(tmp_path: Path) -> None:
    shutil.copy(OLD_STORE, tmp_path / "sessions.db")
    with SessionStore(tmp_path, read_only=True) as store:
        sessions = store.list_sessions()
        measured = {s.note: session_metrics(store.events(s.id), s.clock) for s in sessions}
        # Read from the rows of a store older than the events' times: the same.
        assert stored_metrics(store, sessions) == list(measured.values())
    for m in measured.values():
        assert not m.timed and m.events > 0
        times = [k for k in METRIC_KEYS if k.endswith("_s") or k.endswith("_share")]
        assert all(getattr(m, k) is None for k in times)
    assert measured["old repair"].repairs == 1
    assert measured["seed 2; old camera"].camera_answers > 0
    assert measured["seed 1; old voice"].voice_answers > 0
    nothing = session_metrics([], "simulated").row()
    assert nothing == {k: (0 if k in _COUNTS else None) for k in METRIC_KEYS} | {"timed": False}


_COUNTS = {
    "events", "steps", "askHelp", "offerHelp", "confirmAttach", "requests", "repairs",
    "fallbacks", "camera_answers", "voice_answers",
}  # fmt: skip


def test_a_simulated_session_adds_up() -> None:
    plan = default_plan()
    for seed in range(6):
        executor = Executor(plan, RandomSource(seed), timeline=SimulatedTimeline(seed))
        assert executor.run() == "goal"
        m = session_metrics(executor.events, executor.timeline.clock)
        assert m.timed and m.task_s is not None and m.task_s > 0
        assert m.robot_active_s is not None and m.robot_idle_s is not None
        assert m.robot_active_s + m.robot_idle_s == pytest.approx(m.task_s)
        assert m.human_active_s is not None and m.concurrent_s is not None
        assert m.concurrent_s <= min(m.robot_active_s, m.human_active_s)


def test_the_cli_writes_csv_and_json_and_refuses_an_unknown_study(tmp_path: Path) -> None:
    shutil.copy(OLD_STORE, tmp_path / "sessions.db")
    plan = default_plan()
    with SessionStore(tmp_path) as store:
        session = store.start(plan, clock="simulated")
        timeline = SimulatedTimeline(4, origin=3_000.0)
        Executor(plan, RandomSource(4), [store.recorder(session)], timeline=timeline).run()
        store.finish(session, "goal")
        expected = session_metrics(store.events(session), "simulated").row()

    def tandem(*args: str) -> subprocess.CompletedProcess[str]:
        command = [*tandem_command(), "sessions", "metrics", *args, "--data-dir", str(tmp_path)]
        return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)

    out = tmp_path / "metrics.csv"
    assert tandem("-o", str(out)).returncode == 0
    rows = list(csv.DictReader(out.open(encoding="utf-8")))
    assert [r["session"] for r in rows] == ["1", "2", "3", "4", str(session)]
    assert [r["timed"] for r in rows] == ["False"] * 4 + ["True"]
    assert float(rows[-1]["task_s"]) == pytest.approx(expected["task_s"])
    one = json.loads(tandem(str(session), "--json").stdout)
    assert len(one) == 1 and one[0]["session"] == session
    assert {k: one[0][k] for k in METRIC_KEYS} == expected
    assert len(json.loads(tandem("--scenario", "paper-base-ko", "--json").stdout)) == 1
    refused = tandem("--study", "pilot")
    assert refused.returncode == 2
    assert refused.stderr.strip().count("\n") == 0 and "no such study" in refused.stderr


def test_a_study_leaves_out_its_interrupted_and_unfinished_sessions(tmp_path: Path) -> None:
    plan = default_plan()
    ended: dict[str, int] = {}
    with SessionStore(tmp_path) as store:
        ensure_table(store.db)
        # Still running: owned by this process, which is alive.
        for k, result in enumerate(("goal", "interrupted", "running", "aborted", "other")):
            session = store.start(plan, clock="simulated")
            timeline = SimulatedTimeline(k, origin=1_000.0 * k)
            Executor(plan, RandomSource(k), [store.recorder(session)], timeline=timeline).run()
            if result != "running":
                store.finish(session, "goal" if result == "other" else result)  # type: ignore[arg-type]
            study = "pilot-2" if result == "other" else "pilot"
            tag(store.db, session, study, "default", k + 1)
            ended[result] = session
        records = {s.id: s for s in store.list_sessions()}
        expected = [
            session_metrics(store.events(ended[r]), "simulated").row() for r in ("goal", "aborted")
        ]
    assert records[ended["running"]].result is None
    command = [*tandem_command(), "sessions", "metrics", "--study", "pilot", "--json",
               "--data-dir", str(tmp_path)]  # fmt: skip
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)
    assert [(r["session"], r["result"]) for r in rows] == [
        (ended["goal"], "goal"), (ended["aborted"], "aborted"),
    ]  # fmt: skip
    assert [{k: r[k] for k in METRIC_KEYS} for r in rows] == expected
    said = done.stderr.strip()
    assert said.count("\n") == 0 and "pilot" in said
    assert said.startswith("2 interrupted or unfinished")
    # Nothing left out: nothing said.
    other = subprocess.run([*command[:-4], "pilot-2", *command[-3:]], cwd=ROOT,
                           capture_output=True, text=True, timeout=120)  # fmt: skip
    assert other.returncode == 0 and other.stderr == ""
    assert [r["session"] for r in json.loads(other.stdout)] == [ended["other"]]
