"""Repair: the human does what no branch expects, the robot plans again and goes on.

Surprises are injected with `tandem execute --responses scripted:FILE` (`!` lines);
each kind ends at the goal on a new plan, the session keeps the repair, and the
review switches plans where the execution did.
"""

from __future__ import annotations

import os
import socket
import subprocess
from pathlib import Path

import pytest

from app.dashboard.review_panel import session_label
from app.execution.events import REPAIR, is_step
from app.execution.surprises import SurpriseError, parse_surprise
from app.sessions.store import SessionStore
from tests.plan_fixtures import ROOT, tandem_command

# The default plan: n3 asks whether the human holds a part (leg1 is already on
# the top at c1); "no, yes, leg2" reaches confirmAttach(leg2,top) at n20.
SURPRISES = {
    "take": ("!take leg2", "I see you picked up the leg2"),
    "putdown": ("no\nyes\nleg2\n!putdown leg2", "I see you put the leg2 down"),
    "attach": ("!attach leg2 top c2", "I see you attached the leg2 to the top at c2"),
    "detach": ("!detach leg1", "I see you took the leg1 off"),
}


def execute(script: str, folder: Path) -> subprocess.CompletedProcess[str]:
    path = folder / "responses.txt"
    path.write_text(script + "\n")
    env = {**os.environ, "TANDEM_DATA_DIR": str(folder / "data")}
    return subprocess.run(
        [*tandem_command(), "execute", "default.toml", "--responses", f"scripted:{path}"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_surprises_change_the_state_as_the_human_did() -> None:
    start = frozenset({"attached(leg1,top,c1)", "humanFree"})
    taken = parse_surprise("take leg2").apply(start)
    assert {"humanHolding", "humanHoldingPart(leg2)"} <= taken and "humanFree" not in taken
    put = parse_surprise("putdown leg2").apply(taken | {"wantToAttach(leg2,top)"})
    assert put == start  # the human's task on leg2 went with it
    on = parse_surprise("attach leg2 top c2").apply(taken)
    assert "attached(leg2,top,c2)" in on and "humanFree" in on
    assert parse_surprise("detach leg1").apply(start) == frozenset({"humanFree"})
    given = parse_surprise("handback leg2 right").apply(taken)
    assert "holding(right,leg2)" in given and "humanHoldingPart(leg2)" not in given
    for text, why in [
        ("take leg1", "attached"),
        ("putdown leg2", "does not hold"),
        ("attach leg2 top c1", "at c1 already"),
        ("detach leg2", "not attached"),
    ]:
        with pytest.raises(SurpriseError, match=why):
            parse_surprise(text).apply(start)
    with pytest.raises(SurpriseError, match="takes 3"):
        parse_surprise("attach leg2 top")
    with pytest.raises(SurpriseError, match="one of"):
        parse_surprise("juggle leg2")


@pytest.mark.parametrize("kind", sorted(SURPRISES))
def test_each_surprise_is_repaired_and_ends_at_the_goal(kind: str, tmp_path: Path) -> None:
    script, words = SURPRISES[kind]
    result = execute(script, tmp_path)
    assert result.returncode == 0, result.stderr
    assert "repair: new plan" in result.stderr and words in result.stderr
    with SessionStore(tmp_path / "data") as store:
        (session,) = store.list_sessions()
        events = store.events(session.id)
        (repair,) = [e for e in events if e.kind == REPAIR]
        assert repair.evidence is not None
        replanned = repair.evidence.replanned
        assert replanned is not None
        new_plan = store.plan(replanned.plan)  # the new plan is stored
        assert replanned.surprise == script.splitlines()[-1][1:]
        assert set(replanned.observed) == set(new_plan.nodes[new_plan.root].state)
        after = [e for e in events[repair.seq + 1 :] if is_step(e)]  # not the human's own
        # The rest of the session walks the new plan from its root to a goal.
        assert after[0].node == new_plan.root and after[-1].kind == "goal"
        for event, following in zip(after, after[1:], strict=False):
            node = new_plan.nodes[event.node]
            assert node.child(event.outcome) == following.node
    assert session.result == "goal"


def test_a_malformed_surprise_is_one_line(tmp_path: Path) -> None:
    result = execute("!attach leg2", tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        f"{tmp_path / 'responses.txt'}:1: 'attach leg2': attach takes 3 name(s), got 1"
    ]


def test_a_surprise_that_cannot_be_planned_is_said_and_the_plan_goes_on(
    tmp_path: Path,
) -> None:
    result = execute("!attach leg2 top c3", tmp_path)  # the top has c1 and c2 only
    assert result.returncode == 0, result.stderr
    assert "surprise ignored: cannot plan after 'attach leg2 top c3'" in result.stderr


def test_the_review_switches_to_the_repaired_plan(tmp_path: Path) -> None:
    from app.dashboard.server import Dashboard, DashboardSettings

    assert execute(SURPRISES["take"][0], tmp_path).returncode == 0
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    dashboard = Dashboard(
        "127.0.0.1",
        port,
        "default.toml",
        DashboardSettings(data_dir=str(tmp_path / "data"), load_models=False),
    )
    try:
        review = dashboard.review
        review.refresh()
        (session,) = dashboard.store.list_sessions()
        review.open(session_label(session))
        first = dashboard.plan
        k = next(i for i, e in enumerate(review.events) if e.kind == REPAIR)
        review.show_step(k)
        assert dashboard.plan is first  # the repair event is still on the old plan
        assert "I'll adapt" in review.summary.content
        review.show_step(k + 1)
        assert dashboard.plan is not first and dashboard.plan is not None
        assert dashboard.selected == dashboard.plan.root
        review.show_step(0)
        assert dashboard.plan is first
    finally:
        dashboard.close()
