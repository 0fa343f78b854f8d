"""The worker side of the search: one branch, a sequential plan from a state.

A `BranchPlanner` grounds the domain once per horizon and solves many states
(ground once, solve many); the coordinator (`planner.search.hcp`) holds one in
its own process, each worker process one, each Ray actor one
(`planner.search.cluster`). What it needs to ground is a `Problem`.
"""

from __future__ import annotations

import multiprocessing as mp
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Future, wait
from dataclasses import dataclass, replace

from planner.search import relevance
from planner.search.encoding import FeasibilityContext
from planner.search.solver import BranchSolver, SequentialPlan, StepProgram, Successor
from planner.search.symmetry import Member
from planner.vocabulary import Action, State

# A branch longer than the horizon is retried with 2, 4, ... times it, up to this factor.
MAX_HORIZON_FACTOR = 8


@dataclass(frozen=True)
class Problem:
    """What a worker needs to ground the domain: facts and feasibility answers."""

    facts: tuple[str, ...]
    reachable: frozenset[tuple[str, str]]
    horizon: int
    skip: tuple[str, ...] = ()
    # Answers that depend on the state alone (solver.HISTORY_FREE): set by the
    # planner whenever several processes or actors solve, so that their number
    # and the schedule never change the plan.
    history_free: bool = False
    # Look for a plan one step shorter than the horizon first (`_sequential`): set
    # by the planner where most milestones cost nothing beyond their steps.
    short_first: bool = False
    # Planning programs preprocessed by clasp, by horizon (`planner.search.preprocessing`):
    # every process solves a horizon with the same program, made once.
    programs: tuple[tuple[int, str], ...] = ()
    # Classes of interchangeable members (`planner.search.symmetry`) whose finished and
    # waiting members a history-free solve leaves out (`planner.search.relevance`).
    members: tuple[tuple[Member, ...], ...] = ()


@dataclass(frozen=True)
class PlannedStep:
    state: State
    action: Action
    chosen: str | None
    outcomes: tuple[Successor, ...]


@dataclass(frozen=True)
class BranchResult:
    """A sequential plan from `start` (empty: `start` is a goal), or None: dead end."""

    start: State
    steps: tuple[PlannedStep, ...] | None
    horizon: int
    solve_s: float
    checks: int
    start_goal: bool = False
    # The plan of an interchangeable state's solve, renamed (`planner.search.symmetry`):
    # no solve of its own.
    reused: bool = False


_worker: BranchPlanner | None = None


class BranchPlanner:
    """Per-process solvers, one per horizon, grounded when first needed."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.context = FeasibilityContext(lambda m, p: (m, p) in problem.reachable)
        self.solvers: dict[int, BranchSolver] = {}
        # Solvers of programs without the members a state's solve leaves out, by
        # horizon and shape (only where answers depend on the state alone: the order
        # of solves in one program decides the others' answers).
        self.relevance = (
            relevance.Relevance(problem.members, problem.facts, problem.reachable)
            if problem.members and problem.history_free
            else None
        )
        self._reduced: dict[tuple[int, relevance.Shape], BranchSolver] = {}
        self._aside: dict[int, Future[BranchSolver]] = {}  # grounding in threads
        # Grounds aside from now on: the first branch lists outcomes within
        # milliseconds of its first solve.
        self.step = StepProgram(problem.facts, self.context, problem.skip)

    def solver(self, horizon: int) -> BranchSolver:
        if horizon not in self.solvers:
            aside = self._aside.pop(horizon, None)
            if aside is None:
                self.solvers[horizon] = self._ground(horizon, self.context)
            else:
                self.solvers[horizon] = made = aside.result()
                self.context.calls += made.context.calls  # counted where it is used
        return self.solvers[horizon]

    def ground_aside(self, horizons: Iterable[int]) -> None:
        """Grounds the solvers of `horizons` in threads of their own, side by side
        (clingo grounds outside the GIL); `solver` waits for them. (No process may be
        forked meanwhile: `settle`.)"""
        for horizon in horizons:
            if horizon in self.solvers or horizon in self._aside:
                continue
            made: Future[BranchSolver] = Future()
            self._aside[horizon] = made
            # A context of its own: two threads must not count calls into one.
            context = FeasibilityContext(self.context.predicate)
            threading.Thread(
                target=_make,
                args=(made, lambda h, c=context: self._ground(h, c), horizon),
                name="tandem-ground",
                daemon=True,
            ).start()

    def settle(self) -> None:
        """Waits until no thread of this planner grounds."""
        wait([*self._aside.values()])
        self.step.settle()

    def _ground(self, horizon: int, context: FeasibilityContext) -> BranchSolver:
        return BranchSolver(
            self.problem.facts,
            horizon,
            context,
            skip=self.problem.skip,
            history_free=self.problem.history_free,
            program=dict(self.problem.programs).get(horizon),
            step=self.step,
        )

    def branch(
        self, start: State, forbid: frozenset[str], *, horizon_first: bool = False
    ) -> BranchResult:
        """The branch from `start`, with the `forbid`den actions banned there.
        `horizon_first`: the horizon's plan is looked for before the one a step short
        (`_sequential`): cheaper where most milestones take the whole horizon."""
        t0 = time.perf_counter()
        calls0 = self.context.calls
        found, horizon = self._sequential(start, forbid, horizon_first)
        planned = None
        if found is not None:
            planned = tuple(
                PlannedStep(
                    s.state,
                    s.action,
                    s.outcome,
                    # Deterministic steps: the plan itself says what follows.
                    (Successor(None, s.after, s.after_goal),)
                    if s.outcome is None
                    else tuple(self.step.outcomes(s.state, s.action)),
                )
                for s in found.steps
            )
        return BranchResult(
            start,
            planned,
            horizon,
            time.perf_counter() - t0,
            self.context.calls - calls0,
            found is not None and found.start_goal,
        )

    def _sequential(
        self, start: State, forbid: frozenset[str], horizon_first: bool = False
    ) -> tuple[SequentialPlan | None, int]:
        """An optimal plan from `start` to its next milestone, and the horizon it is
        optimal for.

        With `Problem.short_first`, a plan one step shorter than the horizon is
        looked for first, in a program a step smaller: most milestones take fewer
        steps (U14: 855 of 865 solves), and such a plan that costs nothing beyond
        its steps is optimal for the horizon too (`solver.STEP_PRIORITY`); other
        plans are looked for again in the horizon's program. A branch that needs
        more steps than the horizon is retried with longer ones before it is
        called a dead end: twice the horizon, then the longest (the dead end's
        proof; grounded only for branches that need it), then those between (the
        plan of the shortest that has one).

        `horizon_first` gives the same answer: the horizon's program holds every plan
        a step short, so where its optimal plan is longer, or costs more than its
        steps, or there is none, no plan a step short costs its steps alone, and the
        search above would come to the horizon's plan too; the plan a step short is
        looked for only where it may win.
        """
        horizon = self.problem.horizon
        known: SequentialPlan | None = None  # the horizon's plan, if looked for already
        looked = False
        if self.problem.short_first and horizon > 1:
            if horizon_first:
                known, looked = self._plan(horizon, start, forbid, whole=True), True
            if not looked or (known is not None and _steps_alone(known, horizon - 1)):
                short = self._plan(horizon - 1, start, forbid, whole=horizon_first)
                if short is not None and short.steps_cost_only:
                    return short, horizon
        found = known if looked else self._plan(horizon, start, forbid, whole=horizon_first)
        longest = self.problem.horizon * MAX_HORIZON_FACTOR
        if found is None and horizon < longest:
            horizon *= 2  # twice the horizon: the longest only where this finds none
            found = self._plan(horizon, start, forbid)
        if found is not None or horizon >= longest:
            return found, horizon
        # Most branches two horizons cannot plan are dead ends, proven only by the
        # longest: it is asked next (a plan within fewer steps is a plan within it
        # too), and the horizons between only where it finds one.
        last = self.solver(longest).plan(start, forbid)
        if last is None:
            return None, longest
        while horizon * 2 < longest:
            horizon *= 2
            found = self.solver(horizon).plan(start, forbid)
            if found is not None:
                return found, horizon
        return last, longest

    def _plan(
        self, horizon: int, start: State, forbid: frozenset[str], *, whole: bool = False
    ) -> SequentialPlan | None:
        """The optimal plan of `horizon` steps from `start`: in a program without the
        members that do not matter to it (`planner.search.relevance`), where some
        do not and the horizon is one every branch is first solved with. `whole`: in
        the whole program (along the first branch, whose states leave out a few
        members more at every milestone: each would ground a program of its own
        before the branch could go on)."""
        first = self.problem.horizon - 1 <= horizon <= self.problem.horizon
        reducing = self.relevance if first and not whole else None
        reduced = reducing.reduce(start, horizon, forbid) if reducing else None
        if reduced is not None:
            found = self._reduced_solver(horizon, reduced.shape).plan(
                reduced.state, reduced.forbidden(forbid)
            )
            if found is not None:
                return reduced.actual_plan(found)
        # A dead end, or a state that keeps every member: the whole program (a dead end
        # without the members is one with them too, but it is rare, and proven here).
        return self.solver(horizon).plan(start, forbid)

    def _reduced_solver(self, horizon: int, shape: relevance.Shape) -> BranchSolver:
        made = self._reduced.get((horizon, shape))
        if made is None:
            assert self.relevance is not None
            facts, reachable = self.relevance.facts_of(shape)
            made = self._reduced[(horizon, shape)] = BranchSolver(
                facts,
                horizon,
                FeasibilityContext(lambda m, p: (m, p) in reachable),
                skip=self.problem.skip,
                history_free=True,
                rules=relevance.RULES,
                externals=relevance.EXTERNALS,
            )
        return made


def _steps_alone(plan: SequentialPlan, steps: int) -> bool:
    """Whether `plan` takes at most `steps` steps and costs nothing beyond them."""
    return plan.steps_cost_only and len(plan.steps) <= steps


def as_solved(problem: Problem, workers: int, *, engine: bool = False) -> Problem:
    """`problem` as a planner with `workers` processes (0: one per core), or an
    engine, solves it: history-free wherever several solve (`Problem.history_free`)."""
    shared = engine or (workers or mp.cpu_count()) > 1
    return replace(problem, history_free=True) if shared else problem


def ground_ahead(problem: Problem) -> Future[BranchPlanner]:
    """The solvers of `problem`, grounded in a thread (clingo grounds outside the
    GIL) before planning starts: a planner given them (`hcp.PlannerSettings.ahead`)
    solves at once if its problem is this one, and grounds anew otherwise."""
    ready: Future[BranchPlanner] = Future()

    def ground() -> None:
        try:
            planner = BranchPlanner(problem)
            planner.solver(problem.horizon)
            planner.step.get()  # its own thread: done too when this future is
            ready.set_result(planner)
        except BaseException as err:  # noqa: BLE001 - the planner grounds anew
            ready.set_exception(err)

    threading.Thread(target=ground, name="tandem-ground-ahead", daemon=True).start()
    return ready


def _make(made: Future[BranchSolver], ground: Callable[[int], BranchSolver], horizon: int) -> None:
    try:
        made.set_result(ground(horizon))
    except BaseException as err:  # noqa: BLE001 - raised again by `solver`
        made.set_exception(err)


_worker_problem: Problem | None = None


def start_worker(problem: Problem) -> None:
    """A worker process's start: its branch planner is made at its first branch. (Large
    benches fork their workers before planning starts, and the first branch is planned
    without them: grounding at once, they took the cores from it.)"""
    global _worker, _worker_problem
    _worker, _worker_problem = None, problem


def run_branch(start: State, forbid: frozenset[str]) -> BranchResult:
    """A branch solved in a worker process (`start_worker`)."""
    global _worker
    if _worker is None:
        assert _worker_problem is not None
        _worker = BranchPlanner(_worker_problem)
    return _worker.branch(start, forbid)
