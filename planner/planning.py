"""From a scenario to a checked `tandem-plan/1` document: the planning pipeline."""

from __future__ import annotations

import multiprocessing as mp
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, wait
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from planner import diagnosis
from planner.collector_pause import cycle_collection_paused
from planner.plan.model import Plan
from planner.scenario.loading import Scenario
from planner.search.branch_planner import BranchPlanner, Problem, as_solved, ground_ahead
from planner.search.cluster import check_address
from planner.search.dag import DagNode, Progress
from planner.search.errors import DeadEnd
from planner.search.hcp import INLINE_SOLVE_S, ConditionalPlanner, PlannerSettings
from planner.search.hoped_planning import HopedPlanning
from planner.search.motion_prefetch import motion_prefetch
from planner.search.plan_building import build_plan, kind_and_action, number_states
from planner.search.preprocessing import ProgramRequest, preprocessed
from planner.search.solving import Engine
from planner.search.symmetry import Symmetry
from planner.talk import conversation
from planner.vocabulary import State

if TYPE_CHECKING:
    from planner.feasibility.checks import BenchChecks
    from planner.feasibility.scene import Site

# Steps per milestone solve; a milestone that needs more is retried with 2x, 4x, 8x.
# Short horizons keep solves at a few milliseconds (paper-05: 1.7 s at 4, 5.0 s at 8).
DEFAULT_HORIZON = 4
# Looking for a plan one step shorter first (`Problem.short_first`) saves about
# 30 % of a solve where that plan costs nothing beyond its steps, and costs one
# more solve where it does: it pays where more than about 70 % of the solves are
# such. Measured shares: U14 93 %, U10 77 %, paper-05 69 %, paper-03 55 %,
# paper-10 9 %, P10 3 %; they are high on large benches where the robot makes
# nearly every goal attachment alone (a part no arm reaches needs the human, and
# asking costs more than steps).
SHORT_FIRST_MAX_HUMAN_SHARE = 0.1
# Benches with this many goal attachments plan for many seconds (U10: 20, 8-20 s
# on 2 cores): their worker processes are forked before planning starts.
LARGE_BENCH_GOALS = 20


def short_first(scenario: Scenario, reachable: frozenset[tuple[str, str]]) -> bool:
    """Whether branches look for a plan one step short of the horizon first."""
    goals = scenario.goal_pairs()
    reached = {part for _, part in reachable}
    human = sum(1 for part, _ in goals if part not in reached)
    return len(goals) >= LARGE_BENCH_GOALS and human <= SHORT_FIRST_MAX_HUMAN_SHARE * len(goals)


def preprocessed_programs(problem: Problem) -> tuple[tuple[int, str], ...]:
    """clasp's preprocessed planning programs (`planner.search.preprocessing`) of the horizons
    branches are first solved with: a step short (`short_first`) and the horizon."""
    horizons = [problem.horizon - 1] if problem.short_first else []
    horizons.append(problem.horizon)
    reachable = tuple(sorted(problem.reachable))
    asked = [ProgramRequest(problem.facts, h, reachable, problem.skip) for h in horizons]
    return tuple(zip(horizons, preprocessed(asked), strict=True))


class PlanningCancelled(Exception):
    """Planning was cancelled before every branch was planned."""


@dataclass
class PlanResult:
    plan: Plan
    first_branch_s: float  # when the first complete, executable branch existed
    solves: int


def initial_state(scenario: Scenario) -> State:
    """Nothing held or attached; the human's hands are unknown unless they can pick nothing up."""
    human_regions = {r.id for r in scenario.regions if r.human_reach}
    can_pick = scenario.human.initiative > 0 and any(
        p.movable and p.region in human_regions for p in scenario.parts
    )
    return frozenset() if can_pick else frozenset({"humanFree"})


@contextmanager
def bench_checks(
    scenario: Scenario, cache_dir: Path | str | None, workers: int = 1
) -> Iterator[BenchChecks | None]:
    """The geometric checks of a scenario whose feasibility source is geometry, else None.

    `cache_dir`: where the check cache lives (None: the default, ":memory:": none);
    `workers`: processes that answer cache misses (0: one per core).
    """
    if scenario.feasibility.source != "geometry":
        yield None
        return
    # Imported here: pybullet and OMPL load only when geometry is asked for.
    from planner.feasibility.cache import CheckCache
    from planner.feasibility.checks import BenchChecks

    workers = workers or mp.cpu_count()
    with (
        CheckCache(cache_dir) as cache,
        BenchChecks(scenario, cache=cache, workers=workers) as checks,
    ):
        yield checks


def feasible_pairs(
    scenario: Scenario,
    checks: BenchChecks | None = None,
    hope: Callable[[dict[tuple[str, str], bool]], None] | None = None,
) -> tuple[frozenset[tuple[str, str]], float]:
    """(arm, part) pairs the robot can reach, and the seconds spent checking them.

    Declared scenarios (no `checks`, see `bench_checks`) answer from their table;
    geometric ones ask `checks` once per pair, in the parent process, so workers share
    the answers (`hope`: see `BenchChecks.answers`).
    """
    if checks is None:
        return frozenset(scenario.reachable_pairs()), 0.0
    t0 = time.perf_counter()
    # Answers alone: the paths of the pool's checks are made while planning runs.
    answers = checks.answers(hope)
    pairs = frozenset(pair for pair, reachable in answers.items() if reachable)
    return pairs, time.perf_counter() - t0


def point_facts(scenario: Scenario, checks: BenchChecks | None) -> list[str]:
    """The facts of the fixed parts' points the arms reach (feasibility.lp), from
    geometry, where the scenario asks for them (`[feasibility] points = "each"`)."""
    if checks is None or scenario.feasibility.points != "each":
        return []
    return _point_facts(checks.point_answers())


def _point_facts(answers: dict[tuple[str, Site], bool]) -> list[str]:
    facts = {f"pointsChecked({site.part})" for _, site in answers}
    facts |= {f"pointReach({arm},{s.part},{s.point})" for (arm, s), ok in answers.items() if ok}
    return sorted(facts)


def _problem(
    scenario: Scenario,
    reachable: frozenset[tuple[str, str]],
    points: list[str],
    start: State | None,
    skip: tuple[str, ...],
) -> tuple[list[str], Problem]:
    """The plan's facts and the problem the planner solves, from the reach answers."""
    facts = sorted([*scenario.facts(reachable), *points])
    if start is not None:
        facts = [*facts, "resumed"]  # conversation.lp: the robot has greeted already
    problem = Problem(
        facts=tuple(f for f in facts if not f.startswith("reachable(")),
        reachable=reachable,
        horizon=DEFAULT_HORIZON,
        skip=skip,
        short_first=short_first(scenario, reachable),
    )
    return facts, problem


def plan_scenario(
    scenario: Scenario,
    *,
    workers: int = 0,
    progress: Callable[[Progress], None] | None = None,
    planner_hook: Callable[[ConditionalPlanner], None] | None = None,
    skip: tuple[str, ...] = (),
    cache_dir: Path | str | None = None,
    check_workers: int | None = None,
    cluster: str | None = None,
    window: int = 0,
    start: State | None = None,
    inline_s: float = INLINE_SOLVE_S,
    symmetry: bool = True,
) -> PlanResult:
    """Plans every contingency of `scenario`; raises `DeadEnd` if no plan exists.

    `start` is the state to plan from (default: the scenario's initial state);
    a repair plans from what was observed.

    `planner_hook` receives the planner before it starts (to cancel it from
    another thread); `skip` leaves encoding concerns out (for ablation tests);
    `cache_dir` is where geometric checks are cached (see `bench_checks`), and
    `check_workers` how many processes check geometry (None: as many as `workers`).
    `cluster` ("auto", "ray://HOST:PORT") solves branches on Ray actors, `workers`
    of them (0: one per CPU of the cluster); `window` is how many states are
    solved side by side (0: two per worker, four on large benches; the plan
    depends on it alone);
    `inline_s` how many seconds of solving this process does before starting the
    worker processes (hcp.INLINE_SOLVE_S; only with hcp.SWITCH_MIN_OPEN states
    open); `symmetry` whether states that differ
    by a renaming of interchangeable parts are solved once (`planner.search.symmetry`).
    """
    if cluster is not None:
        check_address(cluster)  # before the checks: a typo is known at once
    checkers = workers if check_workers is None else check_workers
    options = _SearchOptions(
        workers, progress, planner_hook, skip, cluster, window, start, inline_s, symmetry
    )
    with (
        cycle_collection_paused(),
        bench_checks(scenario, cache_dir, checkers or (1 if cluster else 0)) as checks,
    ):
        return _Planning(scenario, checks, options).run()


@dataclass(frozen=True)
class _SearchOptions:
    """`plan_scenario`'s options that shape the search (see there)."""

    workers: int
    progress: Callable[[Progress], None] | None
    planner_hook: Callable[[ConditionalPlanner], None] | None
    skip: tuple[str, ...]
    cluster: str | None
    window: int
    start: State | None
    inline_s: float
    symmetry: bool


class _Planning:
    """One plan of a scenario, within its geometric checks (None: declared reach):
    the reach answers, the search, then the plan built from its DAG."""

    def __init__(
        self, scenario: Scenario, checks: BenchChecks | None, options: _SearchOptions
    ) -> None:
        self.t0 = time.perf_counter()
        self.scenario = scenario
        self.checks = checks
        self.options = options
        self.large = len(scenario.goal_pairs()) >= LARGE_BENCH_GOALS
        self.root = initial_state(scenario) if options.start is None else options.start
        self.workers = options.workers  # on a cluster: its CPUs, once connected
        self.engine: Engine | None = None
        # The solvers of the hoped answers' problem, grounded in a thread, and the
        # planning on them (`_hope`), while the check processes decide.
        self.ahead: Future[BranchPlanner] | None = None
        self.hoped: HopedPlanning | None = None
        self.hoped_problem: Problem | None = None
        self.first_branch_s: float | None = None  # when the first branch was executable

    def run(self) -> PlanResult:
        """The plan; raises `Unsolvable`, `DeadEnd` explained, or `PlanningCancelled`."""
        try:
            reachable, checks_s = feasible_pairs(self.scenario, self.checks, self._hope)
            # A cause found before the search is an answer in microseconds, not minutes.
            diagnosis.check(self.scenario, reachable)
            facts, problem = self._problem(reachable)
            planner = self._search(problem, reachable)
            plan = self._plan(planner, facts, checks_s)
            first = self.first_branch_s
            return PlanResult(
                plan, plan.statistics["plan_s"] if first is None else first, planner.solves
            )
        finally:
            if self.hoped is not None:
                self.hoped.abandon()  # planning failed or was refused before it ended
            if self.ahead is not None:
                # Its thread may still be grounding: clingo must not be inside it when
                # the process exits (a plan refused by the diagnosis returns at once).
                wait([self.ahead])

    def _problem(self, reachable: frozenset[tuple[str, str]]) -> tuple[list[str], Problem]:
        """The plan's facts and the problem the search solves (on a cluster, its
        actors are started here)."""
        points = point_facts(self.scenario, self.checks)
        facts, problem = _problem(
            self.scenario, reachable, points, self.options.start, self.options.skip
        )
        if self.large:
            # Interchangeable members that no longer matter are left out of solves
            # (`planner.search.relevance`): a large bench's solves are most of its plan.
            members = Symmetry.of(problem.facts, reachable).classes if self.options.symmetry else ()
            problem = replace(problem, programs=preprocessed_programs(problem), members=members)
        if self.options.cluster is not None:
            # Imported only here: without --cluster, Ray is never loaded.
            from planner.search import cluster as ray_cluster

            ray_cluster.connect(self.options.cluster)
            self.workers = self.workers or ray_cluster.cluster_cpus()
            # Actors solve with answers that depend on the state alone (Problem).
            problem = as_solved(problem, self.workers, engine=True)
            self.engine = ray_cluster.BranchActors(problem, self.workers)
        return facts, problem

    def _search(
        self, problem: Problem, reachable: frozenset[tuple[str, str]]
    ) -> ConditionalPlanner:
        """The planner with the complete DAG: the planning on the hoped answers if
        they were the decided ones, else a search started now."""
        hoped = self.hoped
        if hoped is not None and self.hoped_problem != as_solved(problem, self.workers):
            hoped.abandon()  # answers other than the hoped ones: planned anew
            hoped = None
        try:
            if hoped is not None:
                hoped.confirm()
                planner = hoped.planner
                hoped.result()
            else:
                planner = self._planner_for(problem, reachable)
                planner.build(self.root)
        except DeadEnd as err:
            raise diagnosis.explain(err, self.scenario, reachable) from err
        if planner.cancelled:
            raise PlanningCancelled(f"cancelled after {planner.solves} solves")
        return planner

    def _plan(self, planner: ConditionalPlanner, facts: list[str], checks_s: float) -> Plan:
        """The plan of the complete DAG, with what the robot says and (geometry) its
        motions; `checks_s`: the seconds the reach checks took."""
        # What the robot says is found from the DAG, and the plan is built once, with
        # it (U18: building it without and then putting it in took 2 s more).
        ids = number_states(planner.nodes, self.root)
        views = [_view(node_id, planner.nodes[state]) for state, node_id in ids.items()]
        plan = build_plan(
            planner.nodes,
            self.root,
            scenario_name=self.scenario.name,
            scenario_sha256=self.scenario.sha256,
            facts=facts,
            timings=(time.perf_counter() - self.t0, checks_s),
            ids=ids,
            said=conversation.talk_about(sorted(facts), ids[self.root], views),
        )
        plan.statistics["plan_s"] = round(time.perf_counter() - self.t0, 3)
        if self.checks is not None:
            # Paths only for the actions the plan uses, once it is built: the solver
            # needs reachability alone.
            from planner.feasibility.plan_motions import add_motions

            t_motion = time.perf_counter()
            add_motions(plan, self.checks)
            checks_s += time.perf_counter() - t_motion
            plan.statistics["plan_s"] = round(time.perf_counter() - self.t0, 3)
            plan.statistics["checks_s"] = round(checks_s, 3)
        return plan

    def _planner_for(
        self, problem: Problem, reachable: frozenset[tuple[str, str]]
    ) -> ConditionalPlanner:
        options = self.options
        settings = PlannerSettings(
            workers=self.workers,
            window=options.window,
            inline_s=options.inline_s,
            fork_at_start=self.large,
            engine=self.engine,
            symmetry=_symmetry(problem, reachable) if options.symmetry else None,
            ahead=self.ahead,
        )
        checks = self.checks
        prefetch = None if checks is None else motion_prefetch(checks, self._first_branch_done)
        planner = ConditionalPlanner(
            problem,
            self.scenario.goal_pairs(),
            settings,
            progress=options.progress,
            on_first_branch=self._on_first_branch,
            on_planned=prefetch,
        )
        if options.planner_hook:
            options.planner_hook(planner)
        return planner

    def _first_branch_done(self) -> bool:
        return self.first_branch_s is not None

    def _on_first_branch(self, _: dict[State, DagNode]) -> None:
        if self.first_branch_s is None:
            self.first_branch_s = time.perf_counter() - self.t0
        if self.checks is not None:
            self.checks.release_paths()  # smoothing the reach paths may take the cores now

    def _hope(self, answers: dict[tuple[str, str], bool]) -> None:
        """While the check processes decide, the program of the answers hoped for is
        ground, and planned on (`planner.search.hoped_planning`)."""
        if self.large or self.options.cluster is not None:
            return  # their programs are made elsewhere (preprocessing, actors)
        from planner.feasibility.scene import Site

        reach = frozenset(p for p, ok in answers.items() if ok and Site.parse(p[1]) is None)
        sites = {(m, s): ok for (m, t), ok in answers.items() if (s := Site.parse(t)) is not None}
        options = self.options
        try:
            _, problem = _problem(
                self.scenario, reach, _point_facts(sites), options.start, options.skip
            )
        except Exception:  # noqa: BLE001 - the same facts from the real answers say why
            return
        problem = as_solved(problem, self.workers)
        self.ahead = ground_ahead(problem)
        self.hoped_problem = problem
        self.hoped = HopedPlanning(self._planner_for(problem, reach), self.root)


def _symmetry(problem: Problem, reachable: frozenset[tuple[str, str]]) -> Symmetry:
    """The interchangeable members of `problem` (found once: a large bench's problem
    names them already)."""
    return Symmetry(problem.members) if problem.members else Symmetry.of(problem.facts, reachable)


def _view(node_id: str, node: DagNode) -> conversation.NodeView:
    """A complete DAG's node as its plan node will read (`build_plan`)."""
    return (node_id, *kind_and_action(node), node.state)
