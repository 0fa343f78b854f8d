"""Hybrid conditional planning: a DAG of sequential plans over every outcome.

The builder asks for an optimal sequential plan from the start state (the
solver picks the outcome of each nondeterministic action), then plans again
from the state after every other outcome, until every leaf is a goal. Each
distinct state is planned once, so the plan is a DAG; states equal up to a
renaming of interchangeable parts share one solve (`planner.search.symmetry`). Solves run in the
coordinator's process, and in worker processes once planning has taken
INLINE_SOLVE_S with SWITCH_MIN_OPEN states still open, each holding its own
grounded program (ground once, solve many).
An outcome from which the goal cannot be reached bans the action that led to
it and plans its parent again; a dead end at the start state is reported. A
branch that leads back to a state before it (a loop: the plan must be a DAG)
has the action that closes the loop banned, and is planned again.
"""

from __future__ import annotations

import multiprocessing as mp
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field, replace
from typing import Protocol

from planner.plan import walks
from planner.search.encoding import FeasibilityContext
from planner.search.solver import BranchSolver, SequentialPlan, StepProgram, Successor
from planner.search.symmetry import Renaming, Symmetry
from planner.vocabulary import Action, State, parse_action

MAX_HORIZON_FACTOR = 8
# CPU seconds of planning done in the coordinator's own process before worker
# processes start. Forking them and grounding the domain once more in each costs
# more than most plans take, and on a busy machine every result waits for their
# scheduling. Where states are solved never changes the plan (the window alone does).
INLINE_SOLVE_S = 2.0
# ... and only while this many states at least are open: a plan near its end is
# finished here. When paper-05 and U7 reach INLINE_SOLVE_S, 60 and 48 states are
# open and 62 and 42 solves remain (0.3-0.4 s here, against 0.7 CPU-s of forking
# and grounding twice, beside the check processes' motions): paper-05 cold took
# 3.34 s, not 3.53 s, solved here to the end (median of 5). U8 and U9 have 122
# and 128 open then, and 331 and 240 solves to go.
SWITCH_MIN_OPEN = 100
# How often planning reports progress and newly planned nodes while it goes on.
TELL_EVERY_S = 0.1


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


class DeadEnd(Exception):
    """No conditional plan: the start state cannot reach the goal under every outcome."""


class Engine(Protocol):
    """Solves branches elsewhere (e.g. `planner.search.cluster.BranchActors`)."""

    def submit(self, state: State, forbid: frozenset[str]) -> Future[BranchResult]: ...

    def close(self) -> None: ...


@dataclass
class Progress:
    done: int
    open: int
    solves: int
    elapsed_s: float


# --- worker side -----------------------------------------------------------

_worker: BranchPlanner | None = None


class BranchPlanner:
    """Per-process solvers, one per horizon, grounded when first needed."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.context = FeasibilityContext(lambda m, p: (m, p) in problem.reachable)
        self.solvers: dict[int, BranchSolver] = {}
        # Grounds aside from now on: the first branch lists outcomes within
        # milliseconds of its first solve.
        self.step = StepProgram(problem.facts, self.context, problem.skip)

    def solver(self, horizon: int) -> BranchSolver:
        if horizon not in self.solvers:
            self.solvers[horizon] = BranchSolver(
                self.problem.facts,
                horizon,
                self.context,
                skip=self.problem.skip,
                history_free=self.problem.history_free,
                program=dict(self.problem.programs).get(horizon),
                step=self.step,
            )
        return self.solvers[horizon]

    def branch(self, start: State, forbid: frozenset[str]) -> BranchResult:
        t0 = time.perf_counter()
        calls0 = self.context.calls
        found, horizon = self._sequential(start, forbid)
        planned = None
        if found is not None:
            solver = self.solver(self.problem.horizon)
            planned = tuple(
                PlannedStep(
                    s.state,
                    s.action,
                    s.outcome,
                    # Deterministic steps: the plan itself says what follows.
                    (Successor(None, s.after, s.after_goal),)
                    if s.outcome is None
                    else tuple(solver.outcomes(s.state, s.action)),
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
        self, start: State, forbid: frozenset[str]
    ) -> tuple[SequentialPlan | None, int]:
        """An optimal plan from `start` to its next milestone, and the horizon it is
        optimal for.

        With `Problem.short_first`, a plan one step shorter than the horizon is
        looked for first, in a program a step smaller: most milestones take fewer
        steps (U14: 855 of 865 solves), and such a plan that costs nothing beyond
        its steps is optimal for the horizon too (`solver.STEP_PRIORITY`); other
        plans are looked for again in the horizon's program. A branch that needs
        more steps than the horizon is retried with longer ones before it is
        called a dead end.
        """
        horizon = self.problem.horizon
        if self.problem.short_first and horizon > 1:
            short = self.solver(horizon - 1).plan(start, forbid)
            if short is not None and short.steps_cost_only:
                return short, horizon
        while True:
            found = self.solver(horizon).plan(start, forbid)
            if found is not None or horizon * 2 > self.problem.horizon * MAX_HORIZON_FACTOR:
                return found, horizon
            horizon *= 2


def as_solved(problem: Problem, workers: int, *, engine: bool = False) -> Problem:
    """`problem` as a planner with `workers` processes (0: one per core), or an
    engine, solves it: history-free wherever several solve (`Problem.history_free`)."""
    shared = engine or (workers or mp.cpu_count()) > 1
    return replace(problem, history_free=True) if shared else problem


def ground_ahead(problem: Problem) -> Future[BranchPlanner]:
    """The solvers of `problem`, grounded in a thread (clingo grounds outside the
    GIL) before planning starts: a planner given them (`ConditionalPlanner(ahead=...)`)
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


def _init_worker(problem: Problem) -> None:
    global _worker
    _worker = BranchPlanner(problem)


def _run_branch(start: State, forbid: frozenset[str]) -> BranchResult:
    assert _worker is not None
    return _worker.branch(start, forbid)


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


# --- coordinator -------------------------------------------------------------


class ConditionalPlanner:
    """Builds the plan DAG; `progress` is called after each branch, `cancel()` stops."""

    def __init__(
        self,
        problem: Problem,
        goal_pairs: Iterable[tuple[str, str]],
        *,
        workers: int = 0,
        progress: Callable[[Progress], None] | None = None,
        on_first_branch: Callable[[dict[State, DagNode]], None] | None = None,
        window: int = 0,
        engine: Engine | None = None,
        inline_s: float = INLINE_SOLVE_S,
        on_planned: Callable[[list[DagNode]], None] | None = None,
        fork_at_start: bool = False,
        symmetry: Symmetry | None = None,
        ahead: Future[BranchPlanner] | None = None,
    ) -> None:
        self.goal_pairs = tuple(goal_pairs)
        self.workers = workers or mp.cpu_count()
        self.problem = as_solved(problem, self.workers, engine=engine is not None)
        # How many solves may be pending at once (`build`); the plan depends on it,
        # never on the number of workers or which finished first (0: two per
        # worker, four for a plan known to be large: with rounds, U18 waited less
        # for their slowest solve, 18 % less building with 2 workers).
        self.window = window or (4 if fork_at_start else 2) * self.workers
        self.engine = engine
        self.inline_s = inline_s
        # Solvers grounded before planning started (`ground_ahead`), maybe for
        # another problem: used by this process's solving if they fit.
        self.ahead = ahead
        # A plan known to be large forks its worker processes before planning
        # starts (see `build`); small plans never pay for forking.
        self.fork_at_start = fork_at_start
        # States that are the same problem under other names of interchangeable
        # parts are solved once (`planner.search.symmetry`): solves by canonical state
        # and forbidden actions.
        self.symmetry = symmetry if symmetry else None
        self._solving: dict[tuple[State, frozenset[str]], Future[BranchResult]] = {}
        self._reusing: set[Future[BranchResult]] = set()  # asked, and solved for another state
        # Told a few times a second which nodes got an action (e.g. to start their motions).
        self.on_planned = on_planned
        self._fresh: list[DagNode] = []
        # (solved results integrated when it was asked, seconds) of every solve, in
        # the order asked, and the coordinator's seconds spent integrating results:
        # enough to replay the run on more workers (app.benchmark.scaling).
        self.trace: list[tuple[int, float]] = []
        self.integrate_s = 0.0
        self.progress = progress
        self.on_first_branch = on_first_branch
        self.nodes: dict[State, DagNode] = {}
        self.parents: dict[State, set[State]] = {}
        self.dead_ends: list[str] = []
        self.solves = 0
        self.sent_away = 0  # states asked of worker processes or an engine
        self.solve_s = 0.0
        self.checks = 0
        self._cancel = threading.Event()
        self.root: State = frozenset()
        self._pool: ProcessPoolExecutor | None = None
        self._local: BranchPlanner | None = None  # this process's solvers, if it solves

    def cancel(self) -> None:
        self._cancel.set()

    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    def build(self, root: State) -> State:
        """Plan from `root`; returns it (the DAG is in `self.nodes`)."""
        t0 = time.perf_counter()
        self.root = root
        self._node(root)
        queue: deque[State] = deque([root])
        # Asked and not yet integrated, in the order asked (dicts keep it), each
        # with how many solved results had been integrated when it was asked.
        pending: dict[Future[BranchResult], tuple[State, int]] = {}
        first_done = False
        integrated = 0
        inline = self.engine is None and (self.workers <= 1 or self.inline_s > 0)
        if inline and self.fork_at_start and self.workers > 1:
            # The worker processes are forked now, idle until the switch: forked
            # after this process has ground and solved, their own programs land in
            # its fragmented heap, and their solves were 25 % slower (U14). (The
            # first submit forks them all.)
            self._start_pool().submit(int)
        executor = self._inline() if inline else self._executor()
        cpu0 = time.process_time()  # CPU, not wall: a busy machine must not hurry the switch
        told = 0.0  # the first result is reported at once
        try:
            while not self.cancelled:
                if not (queue or pending):
                    # Every state is planned; a branch that led back to a state
                    # before it is planned again without the action that closed
                    # the loop (the plan must be a DAG), and planning goes on.
                    queue.extend(self._break_loop())
                    if not queue:
                        break
                if (
                    inline
                    and self.workers > 1
                    and time.process_time() - cpu0 >= self.inline_s
                    and len(queue) + len(pending) >= SWITCH_MIN_OPEN
                ):
                    # A long plan: on to the worker processes (what was solved inline
                    # is done, and is integrated as if solved there).
                    inline, executor = False, self._executor()
                # The window slides: after each result is integrated, states are asked
                # until `width` solves are pending again. Results are integrated one at
                # a time in the order they were asked for, and states are asked only
                # between two integrations, so what is asked depends on the results
                # alone, never on which finished first or how many workers there
                # are: a scenario and a window always give the same plan. No worker
                # waits for a round's slowest solve, and the coordinator's work
                # overlaps the workers' solving.
                # Until the first branch reaches a goal, the window holds only the
                # head of the queue, the continuation of the hoped-for branch: the
                # first executable branch waits for its own solves alone.
                width = self.window if first_done else 1
                # (A state interchangeable with one asked before takes no place in
                # the window: it needs no solve of its own.)
                if queue and len(pending) - len(self._reusing) < width:
                    asked = {state for state, _ in pending.values()}
                    while queue and len(pending) - len(self._reusing) < width:
                        state = queue.popleft()
                        node = self.nodes.get(state)
                        if node is None or node.action is not None or node.goal:
                            continue
                        if state in asked:
                            continue
                        asked.add(state)
                        fut = self._ask(executor, state, frozenset(node.forbidden))
                        self.sent_away += 0 if inline else 1
                        pending[fut] = (state, integrated)
                if not pending:
                    continue
                head = next(iter(pending))
                if not head.done():
                    if time.perf_counter() - told >= TELL_EVERY_S:
                        self._tell(t0, len(queue) + len(pending))
                        told = time.perf_counter()
                    wait([head], timeout=TELL_EVERY_S)
                    continue
                t_result = time.perf_counter()
                _, asked_after = pending.pop(head)
                self._reusing.discard(head)
                result = head.result()
                if not result.reused:
                    self.trace.append((asked_after, result.solve_s))
                    self.solves += 1
                    integrated += 1
                self.solve_s += result.solve_s
                self.checks += result.checks
                ahead, later = self._integrate(result, root)
                # The hoped-for branch is continued first: it is the one that
                # becomes executable first (anytime planning).
                queue.extendleft(reversed(ahead))
                queue.extend(later)
                if not first_done and self._expected_branch_done(root):
                    first_done = True
                    if self.on_first_branch:
                        self.on_first_branch(self.nodes)
                self.integrate_s += time.perf_counter() - t_result
                if t_result - told >= TELL_EVERY_S:
                    self._tell(t0, len(queue) + len(pending))
                    told = time.perf_counter()
            self._tell(t0, len(queue) + len(pending))
        finally:
            self._shutdown()
        if not self.cancelled:
            self._prune(root)
        return root

    # -- execution backends
    def _ask(
        self,
        executor: Callable[[State, frozenset[str]], Future[BranchResult]],
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

        def renamed(done: Future[BranchResult]) -> None:
            try:
                mine.set_result(_renamed(done.result(), state, renaming, reused))
            except BaseException as err:  # noqa: BLE001 - handed on to the coordinator
                mine.set_exception(err)

        solving.add_done_callback(renamed)
        if reused:
            self._reusing.add(mine)
        return mine

    def _inline(self) -> Callable[[State, frozenset[str]], Future[BranchResult]]:
        planner = self._local = self._grounded_ahead() or BranchPlanner(self.problem)

        def inline(state: State, forbid: frozenset[str]) -> Future[BranchResult]:
            fut: Future[BranchResult] = Future()
            fut.set_result(planner.branch(state, forbid))
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

    def _executor(self) -> Callable[[State, frozenset[str]], Future[BranchResult]]:
        if self.engine is not None:
            return self.engine.submit
        if self.workers <= 1:
            return self._inline()
        pool = self._start_pool()

        def remote(state: State, forbid: frozenset[str]) -> Future[BranchResult]:
            return pool.submit(_run_branch, state, forbid)

        return remote

    def _start_pool(self) -> ProcessPoolExecutor:
        """The worker processes' pool, made once. (Its processes are forked at its first
        submit.) Not while a thread of this process grounds: a fork copies the locks
        clingo holds in that thread, and the children would wait for them forever.
        Planning may start before the program `ground_ahead` grounds is ready
        (`planner.search.hoped_planning`)."""
        if self._pool is None:
            if self.ahead is not None:
                wait([self.ahead])
            if self._local is not None:
                self._local.step.settle()
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=mp.get_context("fork"),
                initializer=_init_worker,
                initargs=(self.problem,),
            )
        return self._pool

    def _shutdown(self) -> None:
        if self._local is not None:
            # Its one-step program grounds in a thread of its own: clingo must not be
            # inside it when the process exits (a plan can fail within milliseconds).
            self._local.step.settle()
        if self.engine is not None:
            self.engine.close()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    # -- DAG maintenance
    def _node(self, state: State, goal: bool = False) -> DagNode:
        """The node of `state`; `goal` as the solver said (the root learns it from its solve)."""
        node = self.nodes.get(state)
        if node is None:
            node = self.nodes[state] = DagNode(state, goal=goal)
            self.parents.setdefault(state, set())
        return node

    def _expected_branch_done(self, root: State) -> bool:
        """True when the branch of hoped-for outcomes reaches a goal."""
        state, seen = root, set()
        while state not in seen:
            seen.add(state)
            node = self.nodes[state]
            if node.goal:
                return True
            if node.action is None:
                return False
            state = dict(node.children).get(node.expected, node.children[0][1])
        return False

    def _integrate(self, result: BranchResult, root: State) -> tuple[list[State], list[State]]:
        """Adds a branch to the DAG; returns the states that now need a plan:
        the continuation of the hoped-for branch, and the others."""
        start = self.nodes.get(result.start)
        if start is None or start.action is not None:
            return [], []  # planned meanwhile along another branch
        if result.steps is None:
            return [], self._dead_end(result.start, root, result.horizon)
        if result.start_goal:
            start.goal = True
            return [], []
        ahead: list[State] = []
        todo: list[State] = []
        for step in result.steps:
            node = self._node(step.state)
            if node.action is not None or node.goal:
                break  # the rest of this branch is already planned
            node.action = step.action
            self._fresh.append(node)
            node.children = [(o.label, o.state) for o in step.outcomes]
            node.expected = step.chosen
            last = step is result.steps[-1]
            for outcome in step.outcomes:
                label, succ = outcome.label, outcome.state
                child = self._node(succ, outcome.goal)
                self.parents[succ].add(step.state)
                # Other outcomes need plans of their own; so does the end of
                # this branch when it stopped at a milestone short of the goal.
                if child.action is not None or child.goal:
                    continue
                if label != step.chosen:
                    todo.append(succ)
                elif last:
                    ahead.append(succ)
        return ahead, todo

    def _break_loop(self) -> list[State]:
        """The state whose action closes a loop, with that action banned there and
        its plan undone (to plan it again), or nothing if the DAG has no loop."""
        edge = walks.find_back_edge(self.root, self._successors)
        if edge is None:
            return []
        self._unplan(edge[0])
        return [edge[0]]

    def _unplan(self, state: State) -> None:
        """Bans the action planned at `state` and undoes it there, to plan it again."""
        node = self.nodes[state]
        node.forbidden.add(str(node.action))
        for _, succ in node.children:
            self.parents[succ].discard(state)
        node.action, node.children, node.expected = None, [], None

    def _dead_end(self, state: State, root: State, horizon: int) -> list[State]:
        """Bans the action that led here at every parent and plans those again."""
        why = f"no way to the goal within {horizon} steps from {{{', '.join(sorted(state))}}}"
        self.dead_ends.append(f"{self._branch_to(state, root)}: {why}")
        if state == root:
            if len(self.dead_ends) == 1:
                raise DeadEnd(f"at the start: {why}")
            raise DeadEnd(
                "every choice at the start leads to a dead end; first dead branch: "
                + self.dead_ends[0]
            )
        todo = []
        for parent in list(self.parents.get(state, ())):
            if self.nodes[parent].action is None:
                continue
            self._unplan(parent)
            todo.append(parent)
        return todo

    def _branch_to(self, target: State, root: State) -> str:
        """The branch from the root to `target`, as `action -> outcome` steps."""
        back: dict[State, tuple[State, str]] = {}
        queue = deque([root])
        while queue and target not in back:
            state = queue.popleft()
            node = self.nodes[state]
            for label, succ in node.children:
                if succ not in back and succ != root:
                    shown = f"{node.action} -> {label}" if label is not None else f"{node.action}"
                    back[succ] = (state, shown)
                    queue.append(succ)
        steps: list[str] = []
        state = target
        while state in back:
            state, shown = back[state]
            steps.append(shown)
        return " > ".join(reversed(steps)) or "start"

    def _prune(self, root: State) -> None:
        """Drops nodes no longer reachable (after dead ends). (`build` has broken
        every loop before it ends: `_break_loop`.)"""
        seen = walks.breadth_first(root, self._successors)
        for state in seen:
            node = self.nodes[state]
            if node.action is None and not node.goal:
                raise DeadEnd(f"state left unplanned: {{{', '.join(sorted(state))}}}")
        kept = set(seen)
        self.nodes = {s: n for s, n in self.nodes.items() if s in kept}

    def _successors(self, state: State) -> list[State]:
        return [succ for _, succ in self.nodes[state].children]

    def _tell(self, t0: float, open_count: int) -> None:
        """Hands newly planned nodes to `on_planned` and the progress to `progress`
        (a few times a second, not per result: they look at the whole DAG)."""
        if self.on_planned and self._fresh:
            self.on_planned(self._fresh)
        self._fresh = []
        if self.progress:
            self.progress(self._progress(open_count, t0))

    def _progress(self, open_count: int, t0: float) -> Progress:
        done = sum(1 for n in self.nodes.values() if n.action is not None or n.goal)
        return Progress(done, open_count, self.solves, time.perf_counter() - t0)
