"""What the conditional planner builds and tells: the DAG's nodes, its progress."""

from __future__ import annotations

from dataclasses import dataclass, field

from planner.vocabulary import Action, State


@dataclass(slots=True)
class DagNode:
    """A state of the DAG and what is planned there. (Slotted, and with nothing banned
    sharing one empty set: a large plan has a hundred thousand of them.)"""

    state: State
    action: Action | None = None
    children: list[tuple[str | None, State]] = field(default_factory=list)
    expected: str | None = None  # the outcome the sequential plan hoped for
    forbidden: frozenset[str] = frozenset()  # action texts banned here
    goal: bool = False

    @property
    def kind(self) -> str | None:
        return None if self.action is None else self.action.kind


@dataclass
class Progress:
    done: int
    open: int
    solves: int
    elapsed_s: float
