"""Every action's preconditions and effects, through the real one-step transition program."""

from __future__ import annotations

import pytest

from tests.domain_fixtures import scenario, solver, successor


@pytest.fixture(scope="module")
def bs():  # type: ignore[no-untyped-def]
    return solver(scenario())


FREE = {"humanFree"}


def test_hold_needs_free_arm_reach_and_known_human(bs) -> None:  # type: ignore[no-untyped-def]
    # Busy arm.
    assert successor(bs, {"holding(left,foot2)", "humanFree"}, "hold(left,leg1)") == {}
    # Out of reach (human-only leg).
    assert successor(bs, FREE, "hold(left,leg2)") == {}
    # A shared part while the human's hands are unknown.
    assert successor(bs, set(), "hold(left,foot1)") == {}
    # ...or known to hold it.
    holding = {"humanHolding", "humanHoldingPart(foot1)"}
    assert successor(bs, holding, "hold(left,foot1)") == {}
    assert successor(bs, holding, "hold(left,foot2)") != {}


def test_hold_lapses_knowledge_of_the_human(bs) -> None:  # type: ignore[no-untyped-def]
    after = successor(bs, FREE, "hold(left,leg1)")[None]
    assert after == {"holding(left,leg1)"}  # candidates remain, so humanFree is forgotten


def test_attach_first_free_point_and_goal_only(bs) -> None:  # type: ignore[no-untyped-def]
    state = {"holding(left,leg1)", "humanFree"}
    assert successor(bs, state, "attach(left,top,c1)") == {
        None: {"holding(left,leg1)", "attached(leg1,top,c1)"}
    }
    assert successor(bs, state, "attach(left,top,c2)") == {}  # c1 is free: points are canonical
    full = {"holding(left,leg1)", "attached(leg2,top,c1)", "humanFree"}
    assert successor(bs, full, "attach(left,top,c2)") != {}
    # foot2 is meant for leg2, not leg1.
    assert successor(bs, {"holding(left,foot2)", "humanFree"}, "attach(left,leg1,foot)") == {}


def test_unhold_only_after_attachment(bs) -> None:  # type: ignore[no-untyped-def]
    assert successor(bs, {"holding(left,leg1)", "humanFree"}, "unhold(left)") == {}
    after = successor(
        bs, {"holding(left,leg1)", "attached(leg1,top,c1)", "humanFree"}, "unhold(left)"
    )
    assert after == {None: {"attached(leg1,top,c1)"}}


def test_sense_human_holding(bs) -> None:  # type: ignore[no-untyped-def]
    out = successor(bs, set(), "sense(humanHolding)")
    assert out == {"yes": {"humanHolding"}, "no": {"humanFree"}}
    assert successor(bs, FREE, "sense(humanHolding)") == {}


def test_sense_which_part_spends_the_initiative(bs) -> None:  # type: ignore[no-untyped-def]
    out = successor(bs, {"humanHolding"}, "sense(humanHoldingWhichPart)")
    assert set(out) == {"leg2", "foot1", "foot2"}
    assert out["leg2"] == {"humanHolding", "humanHoldingPart(leg2)", "initiatives(1)"}
    # With the initiative spent nobody is a candidate: the robot stays sure the hands are free.
    after = successor(
        bs, {"initiatives(1)", "attached(foot2,leg2,foot)", "humanFree"}, "hold(left,leg1)"
    )[None]
    assert "humanFree" in after


def test_sense_unholding_and_where(bs) -> None:  # type: ignore[no-untyped-def]
    held = {"humanHolding", "humanHoldingPart(leg2)", "reserved(leg2)"}
    out = successor(bs, held, "sense(humanUnholding(leg2))")
    assert out["yes"] == {"humanFree", "reserved(leg2)"}
    assert out["no"] == held | {"keepsHolding(leg2)"}
    task = {"humanHolding", "humanHoldingPart(leg2)", "acceptToAttach(leg2,top)"}
    assert successor(bs, task, "sense(humanAttachingWhere(leg2,top))") == {
        "c1": {"attached(leg2,top,c1)", "humanFree"}
    }
    assert successor(bs, FREE, "sense(humanAttachingWhere(leg2,top))") == {}


def test_confirm_attach(bs) -> None:  # type: ignore[no-untyped-def]
    held = {"humanHolding", "humanHoldingPart(leg2)"}
    out = successor(bs, held, "confirmAttach(leg2,top)")
    assert out == {"yes": held | {"wantToAttach(leg2,top)"}, "no": held | {"reserved(leg2)"}}


def test_ask_help(bs) -> None:  # type: ignore[no-untyped-def]
    out = successor(bs, FREE, "askHelp(leg2,top)")
    assert out == {
        "yes": {"humanHolding", "humanHoldingPart(leg2)", "acceptToAttach(leg2,top)"},
        "no": {"humanFree", "declined(leg2,top)"},
    }
    assert successor(bs, FREE, "askHelp(leg1,top)") == {}  # the robot can reach leg1 itself


def test_offer_help(bs) -> None:  # type: ignore[no-untyped-def]
    # leg1 must be on the top (shared region) for the human to be able to work on it.
    assert successor(bs, {"humanHolding", "humanHoldingPart(foot1)"}, "offerHelp(foot1,leg1)") == {}
    held = {"humanHolding", "humanHoldingPart(foot1)", "attached(leg1,top,c1)"}
    out = successor(bs, held, "offerHelp(foot1,leg1)")
    assert out == {
        "yes": {"humanFree", "reserved(foot1)", "attached(leg1,top,c1)"},
        "no": held | {"wantToAttach(foot1,leg1)"},
    }
    harmless = {"humanHolding", "humanHoldingPart(foot2)"}
    assert successor(bs, harmless, "offerHelp(foot2,leg2)") == {}  # offers are for dangerous parts


def test_requests(bs) -> None:  # type: ignore[no-untyped-def]
    held = {"humanHolding", "humanHoldingPart(foot2)", "keepsHolding(foot2)", "reserved(foot2)"}
    assert successor(bs, held, "requestToUnhold(foot2)") == {None: {"humanFree", "reserved(foot2)"}}
    assert successor(bs, FREE, "requestToAttach(leg2,top)") == {}  # ask first
    declined = {"humanFree", "declined(leg2,top)"}
    assert successor(bs, declined, "requestToAttach(leg2,top)") == {
        None: {
            "declined(leg2,top)",
            "requestedAttach(leg2,top)",
            "humanHolding",
            "humanHoldingPart(leg2)",
        }
    }


def test_verbosity_shapes_what_the_robot_says() -> None:
    from planner.talk import phrases
    from planner.vocabulary import AskHelp

    ask = AskHelp("leg2", "top")
    terse = phrases.say(ask, "terse")
    normal = phrases.say(ask, "normal")
    chatty = phrases.say(ask, "chatty", "No arm can reach leg2.")
    assert len(terse) < len(normal) < len(chatty)
    assert "leg2" in terse and chatty.endswith("(No arm can reach leg2.)")
