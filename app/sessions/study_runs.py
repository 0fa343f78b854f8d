"""A study's session, run where the store is not, and stored by the study's process.

A study's sessions run in worker processes or as Ray tasks on other machines.
None of them opens the session store: SQLite's locking cannot be trusted on a
network file system, so a store shared by a cluster's nodes could be damaged.
Each task sends its whole session back (`SessionRun`: the plan, the plans of its
repairs, its events, its result and its tags), and the study's process alone
writes it (`store_run`), so the store has one writer wherever the tasks ran.

A run's events are on a simulated clock that starts at 0; `store_run` places
them at the moment the session is stored (its `started`), so a session's events
fall between its start and its end, which is its last event's end (a human's
action may end after the robot's last step).
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from app.execution.events import ExecutionEvent, Result
from app.sessions.store import SessionStore, canonical_json
from app.sessions.studies import tag
from planner.plan.model import Plan


def plan_hash(plan: Plan) -> str:
    """The plan's key in a session store (the sha256 of its canonical JSON)."""
    return hashlib.sha256(canonical_json(plan).encode("utf-8")).hexdigest()


@dataclass
class PlanKeeper:
    """Keeps the plans a session's repairs make, keyed as the store will key them
    (a repair's evidence names its plan by that key)."""

    plans: list[Plan] = field(default_factory=list)

    def keep(self, plan: Plan) -> str:
        self.plans.append(plan)
        return plan_hash(plan)


@dataclass(frozen=True)
class SessionRun:
    """One participant's session in one condition, whole; picklable, so it travels
    back from a worker process or a Ray task."""

    study: str
    condition: str
    participant: int
    note: str
    plan: Plan
    plan_key: str  # `plan_hash(plan)`, worked out once per plan where it ran
    repairs: tuple[Plan, ...]
    events: tuple[ExecutionEvent, ...]  # seconds from the session's start
    result: Result

    @property
    def ended(self) -> float:
        """When the session's last event ended, the human's included (0: none)."""
        return max((_end(e) for e in self.events), default=0.0)


def _end(event: ExecutionEvent) -> float:
    return event.end if event.end is not None else event.time


class Plans:
    """The plans already stored, by key: each plan is serialised for the store once,
    however many sessions bring a copy of it."""

    def __init__(self) -> None:
        self._by_key: dict[str, Plan] = {}

    def one(self, key: str, plan: Plan) -> Plan:
        return self._by_key.setdefault(key, plan)


def store_run(store: SessionStore, run: SessionRun, plans: Plans) -> int:
    """Stores the run as a session owned by this process, on the simulated clock, and
    tags it; its id. Killed half-way, the session is left open and is marked
    interrupted the next time the store is opened, as any session whose process
    is gone."""
    plan = plans.one(run.plan_key, run.plan)
    session_id = store.start(plan, note=run.note, clock="simulated")
    tag(store.db, session_id, run.study, run.condition, run.participant)
    for repair in run.repairs:
        store.add_plan(repair)
    started = store.get(session_id).started
    for event in placed(run.events, started):
        store.record(session_id, event)
    store.finish(session_id, run.result, ended=started + run.ended)
    return session_id


def placed(events: Sequence[ExecutionEvent], origin: float) -> list[ExecutionEvent]:
    """The events with their times moved by `origin` seconds."""

    def at(t: float | None) -> float | None:
        return None if t is None else origin + t

    return [
        replace(e, time=origin + e.time, start=at(e.start), end=at(e.end),
                wait_start=at(e.wait_start))
        for e in events
    ]  # fmt: skip
