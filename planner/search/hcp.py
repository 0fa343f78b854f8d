"""Hybrid conditional planning: a DAG of sequential plans over every outcome.

The builder asks for an optimal sequential plan from the start state (the
solver picks the outcome of each nondeterministic action), then plans again
from the state after every other outcome, until every leaf is a goal. Each
distinct state is planned once, so the plan is a DAG; states equal up to a
renaming of interchangeable parts share one solve (`planner.search.symmetry`). Solves run in the
coordinator's process, and in worker processes once planning has taken
INLINE_SOLVE_S with SWITCH_MIN_OPEN states still open, each holding its own
grounded program (ground once, solve many: `planner.search.branch_planner`).
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
from concurrent.futures import Future, wait
from dataclasses import dataclass, field

from planner.plan import walks
from planner.search.branch_planner import BranchPlanner, BranchResult, Problem, as_solved

# (Also named here, where the planner's users have always found them.)
from planner.search.dag import DagNode as DagNode
from planner.search.dag import Progress as Progress
from planner.search.errors import DeadEnd
from planner.search.solving import Engine, Solve, Solving
from planner.search.symmetry import Symmetry
from planner.vocabulary import State

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


# --- coordinator (its nodes and progress: `planner.search.dag`) ---------------


@dataclass
class _Build:
    """Where one `ConditionalPlanner.build` is: what is queued, asked and integrated."""

    root: State
    t0: float
    solving: Solving
    inline: bool  # solving in this process
    executor: Solve
    queue: deque[State]
    # Asked and not yet integrated, in the order asked (dicts keep it), each
    # with how many solved results had been integrated when it was asked.
    pending: dict[Future[BranchResult], tuple[State, int]] = field(default_factory=dict)
    first_done: bool = False  # the branch of hoped-for outcomes reached a goal
    integrated: int = 0
    # CPU, not wall: a busy machine must not hurry the switch to worker processes.
    cpu0: float = field(default_factory=time.process_time)
    told: float = 0.0  # the first result is reported at once

    @property
    def open(self) -> int:
        return len(self.queue) + len(self.pending)


@dataclass(frozen=True)
class PlannerSettings:
    """How a `ConditionalPlanner` solves its branches. The plan depends on `window`
    alone, never on where or how fast states are solved."""

    workers: int = 0  # processes (0: one per core), or actors of `engine`
    # How many solves may be pending at once (`build`) (0: two per worker, four
    # for a plan known to be large: with rounds, U18 waited less for their slowest
    # solve, 18 % less building with 2 workers).
    window: int = 0
    inline_s: float = INLINE_SOLVE_S  # CPU seconds solved in this process first
    # A plan known to be large forks its worker processes before planning starts
    # (see `build`); small plans never pay for forking.
    fork_at_start: bool = False
    engine: Engine | None = None  # solves branches elsewhere (Ray actors)
    # States that are the same problem under other names of interchangeable parts
    # are solved once (`planner.search.symmetry`).
    symmetry: Symmetry | None = None
    # Solvers grounded before planning started (`ground_ahead`), maybe for another
    # problem: used by this process's solving if they fit.
    ahead: Future[BranchPlanner] | None = None


class ConditionalPlanner:
    """Builds the plan DAG; `progress` is called after each branch, `cancel()` stops.

    `on_first_branch` is told the DAG once the branch of hoped-for outcomes reaches
    a goal, `on_planned` a few times a second which nodes got an action (e.g. to
    start their motions); both, like `progress`, may be replaced before `build`."""

    def __init__(
        self,
        problem: Problem,
        goal_pairs: Iterable[tuple[str, str]],
        settings: PlannerSettings | None = None,
        *,
        progress: Callable[[Progress], None] | None = None,
        on_first_branch: Callable[[dict[State, DagNode]], None] | None = None,
        on_planned: Callable[[list[DagNode]], None] | None = None,
    ) -> None:
        self.settings = settings = settings or PlannerSettings()
        self.goal_pairs = tuple(goal_pairs)
        self.workers = settings.workers or mp.cpu_count()
        self.engine = settings.engine
        self.problem = as_solved(problem, self.workers, engine=self.engine is not None)
        self.window = settings.window or (4 if settings.fork_at_start else 2) * self.workers
        self.symmetry = settings.symmetry if settings.symmetry else None  # none to use
        self.progress = progress
        self.on_first_branch = on_first_branch
        self.on_planned = on_planned
        self._fresh: list[DagNode] = []  # planned since `on_planned` was last told
        # (solved results integrated when it was asked, seconds) of every solve, in
        # the order asked, and the coordinator's seconds spent integrating results:
        # enough to replay the run on more workers (app.benchmark.scaling).
        self.trace: list[tuple[int, float]] = []
        self.integrate_s = 0.0
        self.nodes: dict[State, DagNode] = {}
        self.parents: dict[State, set[State]] = {}
        self.dead_ends: list[str] = []
        self.solves = 0
        self.sent_away = 0  # states asked of worker processes or an engine
        self.solve_s = 0.0
        self.checks = 0
        self._cancel = threading.Event()
        self.root: State = frozenset()
        self._solving: Solving | None = None  # the backends of the build, once started

    @property
    def grounded_ahead(self) -> bool:
        """Whether this process solved with the solvers `settings.ahead` grounded
        (they are for this very problem)."""
        return self._solving is not None and self._solving.grounded_ahead

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
        run = self._start(root, t0)
        try:
            while not self.cancelled and self._step(run):
                pass
            self._tell(t0, run.open)
        finally:
            run.solving.shutdown()
            self.parents = {}  # for dead ends, which come no more (U30: 118,000 sets)
        if not self.cancelled:
            self._prune(root)
        return root

    def _start(self, root: State, t0: float) -> _Build:
        """A build from `root`, solving in this process first unless told otherwise."""
        solving = self._solving = Solving(
            self.problem,
            self.workers,
            engine=self.engine,
            symmetry=self.symmetry,
            ahead=self.settings.ahead,
        )
        inline = self.engine is None and (self.workers <= 1 or self.settings.inline_s > 0)
        if inline and self.settings.fork_at_start and self.workers > 1:
            # The worker processes are forked now, idle until the switch: forked
            # after this process has ground and solved, their own programs land in
            # its fragmented heap, and their solves were 25 % slower (U14). (The
            # first submit forks them all.)
            solving.start_pool().submit(int)
        executor = solving.inline() if inline else solving.executor()
        solving.horizon_first = self.settings.fork_at_start  # until the first branch
        return _Build(root, t0, solving, inline, executor, deque([root]))

    def _step(self, run: _Build) -> bool:
        """Asks what the window allows, then integrates the oldest result asked for,
        or waits a moment for it; False once every state is planned."""
        if not (run.queue or run.pending):
            # Every state is planned; a branch that led back to a state
            # before it is planned again without the action that closed
            # the loop (the plan must be a DAG), and planning goes on.
            run.queue.extend(self._break_loop())
            if not run.queue:
                return False
        if (
            run.inline
            and self.workers > 1
            and time.process_time() - run.cpu0 >= self.settings.inline_s
            and run.open >= SWITCH_MIN_OPEN
            and (run.first_done or not self.settings.fork_at_start)
        ):
            # A long plan: on to the worker processes (what was solved inline
            # is done, and is integrated as if solved there).
            run.inline, run.executor = False, run.solving.executor()
        self._fill_window(run)
        if not run.pending:
            return True
        head = next(iter(run.pending))
        if head.done():
            self._integrate_head(run, head)
        else:
            self._tell_if_due(run, time.perf_counter())
            wait([head], timeout=TELL_EVERY_S)
        return True

    def _fill_window(self, run: _Build) -> None:
        """Asks queued states until the window is full.

        The window slides: after each result is integrated, states are asked
        until `width` solves are pending again. Results are integrated one at
        a time in the order they were asked for, and states are asked only
        between two integrations, so what is asked depends on the results
        alone, never on which finished first or how many workers there
        are: a scenario and a window always give the same plan. No worker
        waits for a round's slowest solve, and the coordinator's work
        overlaps the workers' solving.
        Until the first branch reaches a goal, the window holds only the
        head of the queue, the continuation of the hoped-for branch: the
        first executable branch waits for its own solves alone.
        (A state interchangeable with one asked before takes no place in
        the window: it needs no solve of its own.)
        """
        width = self.window if run.first_done else 1
        if not run.queue or len(run.pending) - len(run.solving.reusing) >= width:
            return
        asked = {state for state, _ in run.pending.values()}
        while run.queue and len(run.pending) - len(run.solving.reusing) < width:
            state = run.queue.popleft()
            node = self.nodes.get(state)
            if node is None or node.action is not None or node.goal or state in asked:
                continue
            asked.add(state)
            fut = run.solving.ask(run.executor, state, node.forbidden)
            self.sent_away += 0 if run.inline else 1
            run.pending[fut] = (state, run.integrated)

    def _integrate_head(self, run: _Build, head: Future[BranchResult]) -> None:
        """Integrates the oldest result asked for, which is done."""
        t_result = time.perf_counter()
        _, asked_after = run.pending.pop(head)
        run.solving.reusing.discard(head)
        result = head.result()
        if not result.reused:
            self.trace.append((asked_after, result.solve_s))
            self.solves += 1
            run.integrated += 1
        self.solve_s += result.solve_s
        self.checks += result.checks
        ahead, later = self._integrate(result, run.root)
        # The hoped-for branch is continued first: it is the one that
        # becomes executable first (anytime planning).
        run.queue.extendleft(reversed(ahead))
        run.queue.extend(later)
        if not run.first_done and self._expected_branch_done(run.root):
            run.first_done = True
            run.solving.horizon_first = False
            if self.on_first_branch:
                self.on_first_branch(self.nodes)
        self.integrate_s += time.perf_counter() - t_result
        self._tell_if_due(run, t_result)

    def _tell_if_due(self, run: _Build, now: float) -> None:
        if now - run.told >= TELL_EVERY_S:
            self._tell(run.t0, run.open)
            run.told = time.perf_counter()

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
            node.expected = step.chosen
            last = step is result.steps[-1]
            for outcome in step.outcomes:
                label, child = outcome.label, self._node(outcome.state, outcome.goal)
                # The DAG holds each state once: edges name the node's own state, not
                # the equal one of this result (U30: 118,000 states, kept two or three
                # times over before).
                succ = child.state
                node.children.append((label, succ))
                self.parents[succ].add(node.state)
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
        node.forbidden |= {str(node.action)}
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
