"""Hoffman's fluency metrics on a session built by hand, each worked out below.

G. Hoffman, "Evaluating Fluency in Human-Robot Collaboration", IEEE THMS 49(3),
2019: robot and human idle time, concurrent activity and functional delay. The
session has a motion, a question whose answer the robot waits for, a request the
human acts on while the robot moves, a gap in which both wait, and a surprising
take during a robot motion; `app/sessions/metrics.py` states the definitions.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from app.execution.events import HUMAN, ExecutionEvent
from app.sessions.metrics import session_metrics
from planner.vocabulary import (
    AskHelp,
    Attach,
    Hold,
    RequestToAttach,
    SenseHumanAttachingWhere,
)

# seq, recorded at its end. Robot steps and the human's actions, in seconds:
#
#   robot  hold(left,leg1)         0 - 3
#   robot  askHelp(leg2,top)       3 - 9   speaks 3 - 5, waits for the answer 5 - 9
#   human  says "yes" (voice)      7 - 9
#   robot  requestToAttach         9 - 11
#   human  attaches leg2 (click)  12 - 16  1 s after the request
#   robot  hold(right,leg3)       13 - 15  while the human attaches
#   (nobody acts 16 - 18)
#   robot  sense attaching        18 - 19
#   robot  attach(left,top,c1)    19 - 23
#   human  takes leg4 (surprise)  20 - 22  seen by the camera, during the motion
#   robot  repair                 23 - 24  planning again
#   goal                          24
ASK = AskHelp("leg2", "top")
REQUEST = RequestToAttach("leg2", "top")
EVENTS = [
    ExecutionEvent(0, 3, "n0", Hold("left", "leg1"), "actuation", start=0, end=3),
    ExecutionEvent(1, 9, "n1", None, HUMAN, source="voice", text="the human says yes",
                   start=7, end=9),
    ExecutionEvent(2, 9, "n1", ASK, "communication", outcome="yes", source="voice",
                   start=3, end=9, wait_start=5),
    ExecutionEvent(3, 11, "n2", REQUEST, "communication", start=9, end=11),
    ExecutionEvent(4, 15, "n3", Hold("right", "leg3"), "actuation", start=13, end=15),
    ExecutionEvent(5, 16, "n2", REQUEST, HUMAN, source="click",
                   text="the human attaches the part", start=12, end=16),
    ExecutionEvent(6, 19, "n4", SenseHumanAttachingWhere("leg2", "top"), "sensing",
                   outcome="c2", source="camera", start=18, end=19),
    ExecutionEvent(7, 22, "n5", None, HUMAN, source="camera", text="take(leg4)",
                   start=20, end=22),
    ExecutionEvent(8, 23, "n5", Attach("left", "top", "c1"), "actuation", start=19, end=23),
    ExecutionEvent(9, 24, "n5", None, "repair", start=23, end=24),
    ExecutionEvent(10, 24, "n6", None, "goal", start=24, end=24),
]  # fmt: skip
SURPRISE = 7
QUESTION = 2


def test_each_metric_against_the_hand_worked_values() -> None:
    m = session_metrics(EVENTS, "wall")
    assert m.timed and m.events == 11 and m.steps == 8
    assert m.task_s == 24  # the first start (0) to the last end (24)
    # Robot active: 0-5 (the hold, then askHelp until its speech ends), 9-11, 13-15,
    # 18-24 (sensing, the attach and the repair back to back) = 5 + 2 + 2 + 6.
    assert m.robot_active_s == 15 and m.robot_idle_s == 9
    # Human active: 7-9 (the answer), 12-16 (the attach), 20-22 (the take) = 2 + 4 + 2.
    assert m.human_active_s == 8 and m.human_idle_s == 16
    # Both active: 13-15 (the robot holds leg3 while the human attaches) and 20-22 (the
    # take during the attach). The answer (7-9) falls in the robot's wait: not both.
    assert m.concurrent_s == 4
    # Nobody acts and one waits for the other: 5-7 (the robot asked, the human has not
    # begun to answer), 11-12 (the request said, the human not started) and 16-18 (the
    # human done, the robot not started) = 2 + 1 + 2.
    assert m.functional_delay_s == 5
    assert m.robot_idle_share == pytest.approx(9 / 24)
    assert m.human_idle_share == pytest.approx(16 / 24)
    assert m.concurrent_share == pytest.approx(4 / 24)
    assert m.functional_delay_share == pytest.approx(5 / 24)
    assert (m.askHelp, m.requests, m.repairs) == (1, 1, 1)
    assert m.askHelp_answer_s == 6  # asked at 3, answered at 9
    assert m.requests_answer_s == 1  # the request ended at 11, the human began at 12


def test_an_answer_wait_is_robot_idle() -> None:
    m = session_metrics(EVENTS, "wall")
    acted_throughout = list(EVENTS)
    acted_throughout[QUESTION] = replace(EVENTS[QUESTION], wait_start=None)
    n = session_metrics(acted_throughout, "wall")
    # Without its wait, askHelp would keep the robot active 5-9: 4 s more, and the
    # 5-7 stretch would no longer be a delay (the robot would be acting).
    assert n.robot_active_s == 19 and n.robot_idle_s == 5
    assert m.robot_idle_s is not None and m.robot_idle_s - n.robot_idle_s == 4
    assert n.functional_delay_s == 3


def test_a_surprising_take_is_human_activity() -> None:
    m = session_metrics(EVENTS, "wall")
    without = session_metrics([e for e in EVENTS if e.seq != SURPRISE], "wall")
    # The take (20-22) is 2 s of the human's activity, all of it during the attach.
    assert without.human_active_s == 6 and without.concurrent_s == 2
    assert m.human_active_s is not None and m.human_active_s - 6 == 2


def test_the_same_on_either_clock_and_untimed_without_one() -> None:
    assert session_metrics(EVENTS, "simulated") == session_metrics(EVENTS, "wall")
    old = session_metrics(EVENTS, None)  # a session stored before clocks
    assert not old.timed and old.task_s is None and old.functional_delay_s is None
    assert (old.steps, old.askHelp, old.requests) == (8, 1, 1)
    missing = [*EVENTS[:-1], replace(EVENTS[-1], start=None)]
    assert not session_metrics(missing, "wall").timed


def test_a_pause_of_one_agent_alone_is_no_delay() -> None:
    # The human is done at 2; the robot acts 2-4, pauses 4-5 and acts 5-6: nobody
    # waited for the other in 4-5 (the robot's own idle time), so no delay.
    events = [
        ExecutionEvent(0, 2, "n0", REQUEST, HUMAN, source="simulated", start=0, end=2),
        ExecutionEvent(1, 4, "n1", Hold("left", "leg1"), "actuation", start=2, end=4),
        ExecutionEvent(2, 6, "n2", Hold("right", "leg2"), "actuation", start=5, end=6),
    ]
    m = session_metrics(events, "simulated")
    assert m.functional_delay_s == 0 and m.robot_idle_s == 3 and m.human_idle_s == 4
