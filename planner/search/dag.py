"""What the conditional planner builds and tells: the DAG's nodes, its progress."""

from __future__ import annotations

from dataclasses import dataclass, field

from planner.vocabulary import Action, State


@dataclass
class DagNode:
    state: State
    action: Action | None = None
    children: list[tuple[str | None, State]] = field(default_factory=list)
    expected: str | None = None  # the outcome the sequential plan hoped for
    forbidden: set[str] = field(default_factory=set)  # action texts banned here
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
