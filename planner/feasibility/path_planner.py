"""Joint-space paths with OMPL (PyPI `ompl` 2.0.1, nanobind bindings).

Binding traps (field notes): the validity callback must return a Python `bool`;
states are read by index (`list(state)` never ends); `bool(status)` is true for an
approximate solution too, so only `haveExactSolutionPath()` counts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

Config = list[float]
RESOLUTION = 0.002  # fraction of the space's extent between checked states (~0.025 rad)
PATH_STEP = 0.05  # radians, largest joint change between consecutive returned states
SMOOTHING_STEPS = 3  # B-spline passes over a simplified path


def seed_ompl(seed: int) -> None:
    """Restart OMPL's global seed sequence, before each query.

    OMPL seeds every new planner's RNG from one global sequence; restarting it per
    query makes each answer depend on that query alone, not on which other checks
    came from the cache, so cold and warm caches give the same paths.
    """
    # OMPL complains (harmlessly) when the sequence has started already.
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(seed % (2**31 - 1) + 1)  # OMPL replaces 0 by 1 with a warning
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)  # "approximate solution" chatter otherwise


@dataclass
class FoundPath:
    """An exact path, not yet simplified: the setup that found it (None: the straight
    segment, nothing to simplify) and its states."""

    setup: og.SimpleSetup | None
    states: list[Config]


def plan_path(
    valid: Callable[[Config], bool],
    start: Sequence[float],
    goal: Sequence[float],
    lower: Sequence[float],
    upper: Sequence[float],
    *,
    planner: str = "RRTConnect",
    time_limit: float = 1.0,
) -> list[Config] | None:
    """A collision-free path from `start` to `goal` inside the joint limits, or None.

    The straight segment is tried first (most queries on an open bench need nothing
    more); then RRTConnect, or RRTstar stopped at its first solution.
    """
    found = find_path(valid, start, goal, lower, upper, planner=planner, time_limit=time_limit)
    return None if found is None else finish_path(found)


def find_path(
    valid: Callable[[Config], bool],
    start: Sequence[float],
    goal: Sequence[float],
    lower: Sequence[float],
    upper: Sequence[float],
    *,
    planner: str = "RRTConnect",
    time_limit: float = 1.0,
) -> FoundPath | None:
    """`plan_path` up to the moment a path is known to exist: whether one does is
    decided here, `finish_path` makes it short and smooth (most of the work)."""
    n = len(start)
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)

    def checker(state: ob.State) -> bool:
        return bool(valid([float(state[i]) for i in range(n)]))

    ss.setStateValidityChecker(checker)
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(RESOLUTION)
    si.setup()  # ss.setup() here would crash: it needs a start and goal first
    a, b = si.allocState(), si.allocState()
    for i in range(n):
        a[i] = float(start[i])
        b[i] = float(goal[i])
    if not (si.isValid(a) and si.isValid(b)):
        return None
    if si.checkMotion(a, b):
        return FoundPath(None, [list(map(float, start)), list(map(float, goal))])
    ss.setStartAndGoalStates(a, b)
    if planner == "RRTstar":
        rrt = og.RRTstar(si)
        objective = ob.PathLengthOptimizationObjective(si)
        # An infinite threshold: any solution satisfies it, so the planner stops at the
        # first one instead of optimising until the time limit.
        objective.setCostThreshold(ob.Cost(math.inf))
        ss.setOptimizationObjective(objective)
        ss.setPlanner(rrt)
    elif planner == "RRTConnect":
        ss.setPlanner(og.RRTConnect(si))
    else:
        raise ValueError(f"unknown planner {planner!r}: expected RRTConnect or RRTstar")
    ss.solve(time_limit)
    if not ss.haveExactSolutionPath():
        return None
    return FoundPath(ss, [])


def finish_path(found: FoundPath, seed: int | None = None) -> list[Config]:
    """The path of `found`, simplified and densified; the validity checker must still
    see the world as `find_path` did (the other arm at home).

    The simplifier may draw on OMPL's global seed sequence (for samplers it makes as
    it goes): with `seed`, the sequence restarts here, so the path does not depend
    on what ran between `find_path` and this call."""
    ss = found.setup
    if ss is None:
        return _densify(found.states)
    if seed is not None:
        seed_ompl(seed)
    path = ss.getSolutionPath()
    n = ss.getSpaceInformation().getStateDimension()
    # A fixed sequence of steps, not a time budget: a timed simplifier returns a
    # different path on a busier machine. Rope shortcutting (deterministic), fewer
    # vertices, then B-spline smoothing: on the paper's benches the paths come out
    # 10-17 % shorter in joint space than with `simplifyMax` (convergence of all
    # its steps), at a third to a quarter of its collision checks.
    simplifier = ss.getPathSimplifier()
    simplifier.ropeShortcutPath(path)
    simplifier.reduceVertices(path)
    simplifier.smoothBSpline(path, SMOOTHING_STEPS)
    states = [[float(path.getState(k)[i]) for i in range(n)] for k in range(path.getStateCount())]
    return _densify(states)


def _densify(states: list[Config]) -> list[Config]:
    """Insert straight-line states so no joint moves more than PATH_STEP per step."""
    out = [states[0]]
    for p, q in zip(states, states[1:], strict=False):
        steps = max(1, math.ceil(max(abs(x - y) for x, y in zip(p, q, strict=True)) / PATH_STEP))
        out.extend(
            [x + (y - x) * k / steps for x, y in zip(p, q, strict=True)] for k in range(1, steps)
        )
        out.append(list(q))  # the state itself, not x + (y - x) rounded: a path ends at its goal
    return out
