"""Where a build's branches are solved: in the coordinator's process, in worker
processes, or by an engine (Ray actors); and once per class of states that are
the same problem under other names of interchangeable parts (`planner.search.symmetry`).

`planner.search.hcp` asks for a branch and gets a Future; which backend answers
never changes the plan (the window alone does).
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor, wait
from dataclasses import replace
from typing import Protocol

from planner.search.branch_planner import (
    BranchPlanner,
    BranchResult,
    PlannedStep,
    Problem,
    run_branch,
    start_worker,
)
from planner.search.solver import Successor
from planner.search.symmetry import Renaming, Symmetry
from planner.vocabulary import State, parse_action

# Solves the branch from a state with some actions forbidden there.
Solve = Callable[[State, frozenset[str]], Future[BranchResult]]


class Engine(Protocol):
    """Solves branches elsewhere (e.g. `planner.search.cluster.BranchActors`)."""

    def submit(self, state: State, forbid: frozenset[str]) -> Future[BranchResult]: ...

    def close(self) -> None: ...


class Solving:
    """The backends of one build: this process's solvers (grounded ahead if they
    fit), the worker processes' pool, or an engine; made when first needed and
    shut down once (`shutdown`)."""

    def __init__(
        self,
        problem: Problem,
        workers: int,
        *,
        engine: Engine | None,
        symmetry: Symmetry | None,
        ahead: Future[BranchPlanner] | None,
    ) -> None:
        self.problem = problem
        self.workers = workers
        self.engine = engine
        self.symmetry = symmetry
        self.ahead = ahead
        # Solves by canonical state and forbidden actions (`ask`).
        self._solving: dict[tuple[State, frozenset[str]], Future[BranchResult]] = {}
        self.reusing: set[Future[BranchResult]] = set()  # asked, and solved for another state
        self._pool: ProcessPoolExecutor | None = None
        self._local: BranchPlanner | None = None  # this process's solvers, if it solves
        # Whether they are the ones `ahead` grounded (its problem is this one).
        self.grounded_ahead = False
        # Whether this process looks for the horizon's plan first (`BranchPlanner.branch`):
        # along a large bench's first branch, where nearly every milestone takes the
        # whole horizon (U30: 57 of its 61; 63 of all 4,293 branches take four steps).
        self.horizon_first = False

    def ask(
        self,
        executor: Solve,
        state: State,
        forbid: frozenset[str],
    ) -> Future[BranchResult]:
        """The branch of `state`: solved, or renamed from the solve of an
        interchangeable state asked before."""
        if self.symmetry is None:
            return executor(state, forbid)
        canon, renaming = self.symmetry.canonical(state)
        if renaming is not None:
            forbid = frozenset(renaming.canonical(a) for a in forbid)
        key = (canon, forbid)
        solving = self._solving.get(key)
        reused = solving is not None
        if solving is None:
            solving = self._solving[key] = executor(canon, forbid)
            if renaming is None:
                return solving
        mine: Future[BranchResult] = Future()
        # A future keeps its callbacks after calling them, so this one lets go of
        # the renamed result once it is handed on (U30: 35,000 renamed branches
        # were kept to the end of planning by the solves they were renamed from).
        job: list[Future[BranchResult]] = [mine]

        def renamed(done: Future[BranchResult]) -> None:
            answer = job.pop()
            try:
                answer.set_result(_renamed(done.result(), state, renaming, reused))
            except BaseException as err:  # noqa: BLE001 - handed on to the coordinator
                answer.set_exception(err)

        solving.add_done_callback(renamed)
        if reused:
            self.reusing.add(mine)
        return mine

    def inline(self) -> Solve:
        ahead = self._grounded_ahead()
        self.grounded_ahead = ahead is not None
        planner = self._local = ahead or BranchPlanner(self.problem)
        # The horizons every branch is first solved with, ground side by side.
        horizon = self.problem.horizon
        short = self.problem.short_first and horizon > 1
        planner.ground_aside([horizon - 1, horizon] if short else [horizon])

        def inline(state: State, forbid: frozenset[str]) -> Future[BranchResult]:
            fut: Future[BranchResult] = Future()
            fut.set_result(planner.branch(state, forbid, horizon_first=self.horizon_first))
            return fut

        return inline

    def _grounded_ahead(self) -> BranchPlanner | None:
        """The solvers `ground_ahead` made, if made for this very problem."""
        if self.ahead is None:
            return None
        try:
            planner = self.ahead.result()
        except Exception:  # noqa: BLE001 - grounded anew, where the error shows
            return None
        return planner if planner.problem == self.problem else None

    def executor(self) -> Solve:
        if self.engine is not None:
            return self.engine.submit
        if self.workers <= 1:
            return self.inline()
        pool = self.start_pool()
        # This process solves no more: its programs go (U30: 90 MB of clingo's).
        self._local = None

        def remote(state: State, forbid: frozenset[str]) -> Future[BranchResult]:
            return pool.submit(run_branch, state, forbid)

        return remote

    def start_pool(self) -> ProcessPoolExecutor:
        """The worker processes' pool, made once. (Its processes are forked at its first
        submit.) Not while a thread of this process grounds: a fork copies the locks
        clingo holds in that thread, and the children would wait for them forever.
        Planning may start before the program `ground_ahead` grounds is ready
        (`planner.search.hoped_planning`)."""
        if self._pool is None:
            if self.ahead is not None:
                wait([self.ahead])
            if self._local is not None:
                self._local.settle()
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=mp.get_context("fork"),
                initializer=start_worker,
                initargs=(self.problem,),
            )
        return self._pool

    def shutdown(self) -> None:
        if self._local is not None:
            # Its programs ground in threads of their own: clingo must not be inside
            # one when the process exits (a plan can fail within milliseconds).
            self._local.settle()
        if self.engine is not None:
            self.engine.close()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        # The solves kept for interchangeable states (U30: 4,293, 60 MB) are done with.
        self._solving.clear()
        self.reusing.clear()


def _renamed(
    result: BranchResult, start: State, renaming: Renaming | None, reused: bool
) -> BranchResult:
    """`result` (a canonical state's) for `start`, parts named back; `reused`: it
    is another state's solve (its time and checks are counted there)."""
    if reused:
        result = replace(result, solve_s=0.0, checks=0, reused=True)
    if result.start == start:
        return result
    assert renaming is not None
    state, text = renaming.actual_state, renaming.actual
    steps = None
    if result.steps is not None:
        steps = tuple(
            PlannedStep(
                state(step.state),
                parse_action(text(str(step.action))),
                None if step.chosen is None else text(step.chosen),
                tuple(
                    Successor(None if o.label is None else text(o.label), state(o.state), o.goal)
                    for o in step.outcomes
                ),
            )
            for step in result.steps
        )
    return replace(result, start=start, steps=steps)
