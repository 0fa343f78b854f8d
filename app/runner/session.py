"""One session's assembly, for every way a plan is run.

The command line (`tandem execute`), a study's participants and the dashboard
run a session from the same parts: the retargeter (the slot the human used
moves later motions), a repairer (a surprise plans again from what was
observed), who answers and who speaks, the clock, the robot. `SessionRunner`
puts them together once; `StoredSession` adds the session store around it:
the session's row written first (a store that cannot be written refuses the
run), each event committed as it happens, and its end. A study's session runs
where no store is (app.sessions.study_runs) and keeps its repairs' plans in
memory instead.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from app.execution.events import Clock, OutcomeSource, Result
from app.execution.repair import Repairer
from app.execution.retargeting import MotionRetargeter, retargeter_for
from app.execution.robot_drive import RobotDriver, ToStart
from app.execution.timing import Timeline
from app.execution.walker import Executor, Listener, Narrator, Player
from app.sessions.store import SessionStore
from planner.plan.model import Plan
from planner.scenario.model import Scenario


def _nothing() -> None:
    return None


@dataclass
class Answering:
    """Who answers a session's branching nodes (`source`), who speaks the robot's
    sentences (`narrator`), who else hears each event (`listeners`, e.g. the
    simulated camera's hands), and what to release when the session ends."""

    source: OutcomeSource
    narrator: Narrator | None = None
    listeners: Sequence[Listener] = ()
    close: Callable[[], None] = _nothing


@dataclass(frozen=True)
class Running:
    """How a session's steps take their time and who makes its motions."""

    timeline: Timeline
    robot: RobotDriver | None = None  # None: the motions are only drawn
    step_delay: float = 0.0
    player: Player | None = None  # plays a drawn motion before its event is kept


class SessionRunner:
    """The executor of one session of `plan` (on `scenario`, its own; None for a plan
    file alone: no re-targeting, no repair)."""

    def __init__(self, plan: Plan, scenario: Scenario | None) -> None:
        self.plan = plan
        self.scenario = scenario
        # Made before the robot is reached: its first motion goes to the plan's start.
        self.retarget: MotionRetargeter | None = retargeter_for(scenario, plan)

    @property
    def to_start(self) -> ToStart | None:
        """The robot's way to the plan's start pose (None: nothing to re-target)."""
        return self.retarget.to_start if self.retarget is not None else None

    def executor(
        self,
        answering: Answering,
        listeners: Sequence[Listener],
        running: Running,
        keep: Callable[[Plan], str],
    ) -> Executor:
        """The executor: `listeners` hear each event first, then `answering`'s;
        `keep(plan)` keeps a repair's plan and returns its key."""
        scenario = self.scenario
        return Executor(
            self.plan,
            answering.source,
            [*listeners, *answering.listeners],
            step_delay=running.step_delay,
            narrator=answering.narrator,
            repairing=Repairer(scenario, keep).repair if scenario is not None else None,
            retarget=self.retarget,
            timeline=running.timeline,
            robot=running.robot,
            player=running.player,
        )


class StoredSession:
    """A session kept in `store` as it runs. Its row is written when it is made (a
    `StoreError` then means the run must not start: it could not be recorded)."""

    def __init__(
        self, store: SessionStore, runner: SessionRunner, *, note: str | None, clock: Clock | None
    ) -> None:
        self.store = store
        self.runner = runner
        self.id = store.start(runner.plan, note=note, clock=clock)

    def executor(
        self, answering: Answering, listeners: Sequence[Listener], running: Running
    ) -> Executor:
        """The session's executor; each event is stored before anyone else hears it."""
        recorder = self.store.recorder(self.id)
        return self.runner.executor(answering, [recorder, *listeners], running, self.store.add_plan)

    def finish(self, executor: Executor, result: Result) -> None:
        """Stores the end: now on the wall clock; on a simulated clock the session
        ends with its last event, not when the program did."""
        ended = None
        if executor.timeline.clock == "simulated":
            ended = max((e.end or 0.0 for e in executor.events), default=None)
        self.store.finish(self.id, result, ended)
