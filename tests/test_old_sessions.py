"""Sessions stored before events and evidence were typed still load, read and replay.

`tests/fixtures/sessions-0.1.db` was written by the code before that change (the
default scenario: a random run, a scripted run with a surprise that was
repaired, a simulated-camera run and a Korean simulated-voice run). Its evidence
is the old flat JSON (version 1); the store reads it into the typed records.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import pytest

from app.execution.events import Outcome, describe, is_step
from app.execution.evidence import EVIDENCE_VERSION, Evidence
from app.execution.walker import Executor
from app.sessions.store import SessionStore
from planner.plan.model import Plan, PlanNode

FIXTURE = Path(__file__).parent / "fixtures" / "sessions-0.1.db"


@pytest.fixture
def store(tmp_path: Path) -> SessionStore:
    shutil.copy(FIXTURE, tmp_path / "sessions.db")
    return SessionStore(tmp_path)


def test_the_old_sessions_are_listed(store: SessionStore) -> None:
    sessions = store.list_sessions()
    assert [s.note for s in sessions] == [
        "seed 3; old random", "old repair", "seed 2; old camera", "seed 1; old voice",
    ]  # fmt: skip
    assert {s.result for s in sessions} == {"goal"}
    assert all(s.events == len(store.events(s.id)) for s in sessions)


def test_old_evidence_reads_as_typed_records(store: SessionStore) -> None:
    camera = [e for e in store.events(3, with_jpeg=True) if e.source == "camera"]
    assert camera
    for e in camera:
        assert e.evidence is not None and e.evidence.camera is not None
        assert e.evidence.camera.decided == "label" and e.evidence.camera.value == e.outcome
        assert e.evidence.camera.frames > 0 and e.evidence.camera.placements
        assert e.evidence.truth is not None and e.evidence.truth.label == e.outcome
        assert e.evidence.jpeg is not None and e.evidence.jpeg.startswith(b"\xff\xd8")
    voice = [e for e in store.events(4) if e.evidence is not None and e.evidence.voice]
    assert voice
    for e in voice:
        assert e.evidence is not None and e.evidence.voice is not None
        assert e.evidence.voice.answered_by == "voice" and e.evidence.voice.attempts
        assert e.evidence.truth is not None and e.evidence.truth.said
        assert e.evidence.truth.label == e.outcome
    spoken = [e for e in store.events(4) if e.evidence is not None and e.evidence.spoken]
    assert spoken and all(e.evidence and e.evidence.spoken.engine == "espeak" for e in spoken)


def test_old_evidence_is_written_back_in_the_new_form(store: SessionStore) -> None:
    for session in store.list_sessions():
        for e in store.events(session.id, with_jpeg=True):
            if e.evidence is None:
                continue
            doc = e.evidence.to_json()
            assert doc["version"] == EVIDENCE_VERSION
            assert Evidence.from_json(doc, e.evidence.jpeg) == e.evidence


def _replayed(store: SessionStore, session_id: int) -> list[tuple[str, str | None]]:
    """The session's path, walked through its plans: each step's node must be where the
    plan leads from the step before; a repair switches to the plan it names."""
    plan = store.plan(store.get(session_id).plan_hash)
    at = plan.root
    path: list[tuple[str, str | None]] = []
    for event in store.events(session_id):
        if event.kind == "repair":
            assert event.evidence is not None and event.evidence.replanned is not None
            plan = store.plan(event.evidence.replanned.plan)
            at = plan.root
            continue
        assert event.node == at, (session_id, event)
        node = plan.nodes[at]
        assert event.action == node.action and event.kind == node.kind
        path.append((event.node, event.outcome))
        if node.kind == "goal":
            break
        following = node.child(event.outcome)
        assert following is not None, (session_id, event)
        at = following
    assert plan.nodes[at].kind == "goal"
    return path


def test_every_old_session_replays_through_its_plans(store: SessionStore) -> None:
    for session in store.list_sessions():
        assert _replayed(store, session.id)
    repairs = [e for e in store.events(2) if e.kind == "repair"]
    assert len(repairs) == 1 and repairs[0].evidence is not None
    assert repairs[0].evidence.replanned is not None
    assert repairs[0].evidence.replanned.surprise == "attach leg2 top c2"


class _Again:
    """Answers as the stored session did, node by node."""

    def __init__(self, answers: Sequence[tuple[str, str | None]]) -> None:
        self.answers = {node: outcome for node, outcome in answers if outcome is not None}

    def choose(self, node_id: str, node: PlanNode, options: Sequence[str]) -> Outcome | None:
        label = self.answers[node_id]
        return Outcome(label, "scripted", 1.0, describe(node.action, label))


@pytest.mark.parametrize("session_id", [1, 3, 4])
def test_an_old_session_runs_again_the_same_way(store: SessionStore, session_id: int) -> None:
    plan: Plan = store.plan(store.get(session_id).plan_hash)
    path = _replayed(store, session_id)
    executor = Executor(plan, _Again(path))
    assert executor.run() == "goal"
    assert [(e.node, e.outcome) for e in executor.events if is_step(e)] == path


def test_tandem_sessions_show_reads_an_old_session(store: SessionStore) -> None:
    shown = subprocess.run(
        [sys.executable, "-m", "app.cli", "sessions", "show", "3", "--data-dir",
         str(store.data_dir)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert "camera: confidence 1.0" in shown.stdout and "agrees" in shown.stdout
