"""Each commonsense, safety and feasibility rule, on a state where breaking it
would give the cheapest plan: without the rule's concern the planner breaks
it, with it the planner does not (real clingo; concerns left out by file)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from planner.vocabulary import parse_action
from tests.domain_fixtures import DEFAULT, actions, scenario, solver

NO_INITIATIVE = ("[robot]", "[human]\ninitiative = 0\n\n[robot]")
DONE_BUT_LEG2 = {"attached(leg1,top,c1)", "attached(foot1,leg1,foot)", "humanFree"}


def test_safety_never_asks_help_with_a_dangerous_part(tmp_path: Path) -> None:
    # foot1 (dangerous) lies where only the human reaches it.
    edit = ('region = "shared"\ndangerous = true', 'region = "humanOnly"\ndangerous = true')
    sc = scenario(edit, NO_INITIATIVE)
    state = frozenset(
        {"humanFree", "attached(leg1,top,c1)", "attached(leg2,top,c2)", "attached(foot2,leg2,foot)"}
    )
    assert "askHelp(foot1,leg1)" in actions(solver(sc, skip=("safety",)).plan(state))
    assert solver(sc).plan(state) is None
    # The whole planner says so, naming the state, instead of returning a partial plan.
    path = tmp_path / "danger.toml"
    path.write_text(DEFAULT.read_text().replace(*edit))
    run = subprocess.run(
        [sys.executable, "-m", "app.cli", "plan", str(path), "--workers", "1"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 1
    assert "no plan" in run.stderr and "Traceback" not in run.stderr
    # It names the cause, with a fix, before any search (tests/test_diagnosis.py;
    # the search's own dead-end report is tested in tests/test_hcp.py).
    assert "foot1 is dangerous and only the human reaches it" in run.stderr
    assert "move foot1 into the shared region, or mark it not dangerous" in run.stderr


def test_safety_never_confirms_a_dangerous_attachment() -> None:
    # Confirming would be as cheap as offering help; only safety tells them apart.
    sc = scenario(NO_INITIATIVE)
    state = frozenset({"humanHolding", "humanHoldingPart(foot1)", "attached(leg1,top,c1)"})
    assert (
        solver(sc, skip=("safety",)).outcomes(state, parse_action("confirmAttach(foot1,leg1)"))
        != []
    )
    bs = solver(sc)
    assert bs.outcomes(state, parse_action("confirmAttach(foot1,leg1)")) == []
    planned = actions(bs.plan(state))
    assert planned[0] == "offerHelp(foot1,leg1)"
    assert not any(a.startswith("confirmAttach(foot1") for a in planned)


def test_safety_never_asks_to_put_a_dangerous_part_down() -> None:
    bs = solver(scenario())
    held = frozenset({"humanHolding", "humanHoldingPart(foot1)", "reserved(foot1)"})
    assert bs.outcomes(held, parse_action("requestToUnhold(foot1)")) == []
    assert (
        bs.outcomes(
            held - {"reserved(foot1)"} | {"humanHoldingPart(foot2)"} - {"humanHoldingPart(foot1)"},
            parse_action("requestToUnhold(foot2)"),
        )
        != []
    )


def test_safety_levels_keep_the_human_out_of_a_region_with_a_dangerous_part() -> None:
    # leg2 lies in the shared region next to the dangerous foot1, out of the
    # robot's reach; foot1 belongs on leg2, so the robot can only take foot1
    # out of the way (hold it) before asking for leg2.
    edits = (
        NO_INITIATIVE,
        (
            'region = "humanOnly"\n\n[[parts]]\nid = "foot1"',
            'region = "shared"\n\n[[parts]]\nid = "foot1"',
        ),
        (
            'right = ["robotOnly", "shared"]',
            'right = ["robotOnly", "shared"]\n\n'
            '[feasibility.unreachable_parts]\nleft = ["leg2"]\nright = ["leg2"]',
        ),
        (
            'table = "stable"',
            'attachments = [["leg1", "top"], ["leg2", "top"], '
            '["foot1", "leg2"], ["foot2", "leg1"]]',
        ),
    )
    state = frozenset({"humanFree", "attached(leg1,top,c1)", "attached(foot2,leg1,foot)"})
    relaxed = scenario(*edits, ('safety = "normal"', 'safety = "relaxed"'))
    assert actions(solver(relaxed).plan(state))[0] == "askHelp(leg2,top)"
    for level in ("normal", "strict"):  # a weak constraint, then a hard one
        sc = scenario(*edits, ('safety = "normal"', f'safety = "{level}"'))
        assert actions(solver(sc, skip=("safety",)).plan(state))[0] == "askHelp(leg2,top)"
        planned = actions(solver(sc).plan(state))
        assert planned[0] in ("hold(left,foot1)", "hold(right,foot1)"), (level, planned)
        assert planned.index("askHelp(leg2,top)") > 0


def test_commonsense_does_not_ask_a_busy_human() -> None:
    sc = scenario(NO_INITIATIVE)
    state = frozenset(
        DONE_BUT_LEG2 - {"humanFree"}
        | {"humanHolding", "humanHoldingPart(foot2)", "reserved(foot2)", "keepsHolding(foot2)"}
    )
    first = actions(solver(sc, skip=("commonsense",)).plan(state))[0]
    assert first in ("askHelp(leg2,top)", "requestToAttach(foot2,leg2)")
    planned = actions(solver(sc).plan(state))
    assert planned[:2] == ["requestToUnhold(foot2)", "askHelp(leg2,top)"]


def test_feasibility_is_hard_for_actuation_and_asks_for_help_instead() -> None:
    sc = scenario(NO_INITIATIVE)
    state = frozenset(DONE_BUT_LEG2)
    assert actions(solver(sc, skip=("feasibility",)).plan(state))[0] == "hold(left,leg2)"
    assert actions(solver(sc).plan(state))[0] == "askHelp(leg2,top)"


def test_purposeful_actuation_holds_only_needed_parts() -> None:
    bs = solver(scenario())
    state = frozenset({"humanFree", "attached(leg1,top,c1)"})
    assert bs.outcomes(state, parse_action("hold(left,leg1)")) == []  # already placed
    assert bs.outcomes(state, parse_action("hold(left,foot1)")) != []
