"""Multi-shot solving: ground the domain once, then plan from any state.

A `BranchSolver` holds two grounded programs: the planning program (horizon
H, milestones and preferences) and the one-step transition program (no
milestones) used to list every outcome of an action. States are passed as
assumptions on the `init/1` externals, so no branch is ever grounded again.
Both show `goalAt/1` (goal.lp), so every state comes back with whether it is
a goal: the goal test is written once, in ASP.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Sequence
from concurrent.futures import Future, wait
from dataclasses import dataclass

import clingo

from planner.search.encoding import PLANNED, FeasibilityContext, ground
from planner.search.preprocessing import load_preprocessed
from planner.vocabulary import Action, State, parse_action

# clasp keeps heuristic scores and learnt constraints from one solve to the next,
# so among equally good plans the one returned depends on which states the
# process solved before. With several workers that history depends on the
# schedule; a static decision order and forgetting everything between solves
# make each answer a function of its state alone (and large instances faster:
# lemmas no longer pile up). One worker keeps clasp's defaults, and its plans.
HISTORY_FREE = ("--heuristic=None", "--forget-on-step=varScores,signs,lemmaScores,lemmas")
# With that static order, core-guided optimisation (clasp's usc) reaches a solve's
# optimum sooner than branch-and-bound: 9 % less solving over every state of U6 and
# U10, and the same optimal model in each of them.
CORE_GUIDED = ("--opt-strategy=usc",)
# The priority of a step's cost (preferences.lp: `:~ occurs(T). [1@1,T]`). A plan
# whose costs above it are all zero is optimal for every longer horizon too: a
# longer plan has more steps, and only costs above the steps' could make it better.
STEP_PRIORITY = 1


@dataclass(frozen=True)
class Step:
    """One action of a sequential plan, in the state before it."""

    state: State
    action: Action
    outcome: str | None  # the outcome the solver chose; None if deterministic
    after: State  # the state after the action, with that outcome
    after_goal: bool  # whether `after` is a goal


@dataclass(frozen=True)
class SequentialPlan:
    """A solver's plan from a state: its steps (none if `start_goal`)."""

    steps: list[Step]
    start_goal: bool
    # No cost above the steps' (STEP_PRIORITY): no longer plan is better.
    steps_cost_only: bool = True


@dataclass(frozen=True)
class Successor:
    """One outcome of an action: its label (None if deterministic) and the state after."""

    label: str | None
    state: State
    goal: bool


class StepProgram:
    """The one-step transition program that lists an action's outcomes
    (`BranchSolver.outcomes`), grounded in a thread of its own from the moment it
    is made: clingo grounds outside the GIL, so this overlaps the grounding and
    solving of the planning program, and the first branch comes sooner."""

    def __init__(
        self, facts: Sequence[str], context: FeasibilityContext, skip: tuple[str, ...] = ()
    ) -> None:
        self._program: Future[tuple[clingo.Control, dict[str, int]]] = Future()
        # A context of its own: two threads must not count calls into one.
        own = FeasibilityContext(context.predicate)
        args = (list(facts), own, tuple(sorted({*skip, "milestones", "lookahead", "preferences"})))
        self._occ: dict[str, int | None] = {}
        self._shown: dict[clingo.Symbol, tuple[str, int, str]] = {}  # `_meaning`, read once
        threading.Thread(target=self._ground, args=args, daemon=True).start()

    def _ground(self, facts: list[str], context: FeasibilityContext, skip: tuple[str, ...]) -> None:
        try:
            ctl = ground(facts, 1, context, skip=skip)
            ctl.configuration.solve.models = 0  # type: ignore[union-attr]
            if PLANNED in facts:
                # The table each model chooses (configuration.lp) is not shown:
                # one model per outcome, not one per table.
                ctl.configuration.solve.project = "show"  # type: ignore[union-attr]
            self._program.set_result((ctl, _externals(ctl, "init")))
        except BaseException as err:  # raised again by `get`
            self._program.set_exception(err)

    def get(self) -> tuple[clingo.Control, dict[str, int]]:
        """The grounded program and its `init/1` externals (waits for the thread)."""
        return self._program.result()

    def outcomes(self, state: State, action: Action) -> list[Successor]:
        """Every outcome of `action` in `state` and the state after it."""
        occ = self._occ_literal(str(action))
        if occ is None:
            return []
        step_ctl, step_fluents = self.get()
        assumptions = _assume(step_fluents, state)
        assumptions.append(occ)
        found: list[Successor] = []

        def on_model(model: clingo.Model) -> None:
            label: str | None = None
            after: set[str] = set()
            goal = False
            for sym in model.symbols(shown=True):
                kind, t, text = _read(self._shown, sym)
                if kind == "out":
                    label = text
                elif kind == "h" and t == 1:
                    after.add(text)
                elif kind == "goalAt" and t == 1:
                    goal = True
            found.append(Successor(label, frozenset(after), goal))

        step_ctl.solve(assumptions=assumptions, on_model=on_model)
        found.sort(key=lambda o: (o.label is None, o.label or ""))
        return found

    def _occ_literal(self, action: str) -> int | None:
        """The literal of `occ(action,0)`; None if grounding found it never possible."""
        if action not in self._occ:
            sym = clingo.Function("occ", [clingo.parse_term(action), clingo.Number(0)])
            atom = self.get()[0].symbolic_atoms[sym]
            self._occ[action] = atom.literal if atom is not None else None
        return self._occ[action]

    def settle(self) -> None:
        """Waits until the thread is done grounding, whether it failed or not."""
        wait([self._program])


@dataclass
class BranchSolver:
    facts: Sequence[str]
    horizon: int
    context: FeasibilityContext
    skip: tuple[str, ...] = ()
    options: tuple[str, ...] = ()
    history_free: bool = False  # see HISTORY_FREE
    # The planning program preprocessed by clasp (`planner.search.preprocessing`), made
    # from these facts and horizon; None: ground here.
    program: str | None = None
    # The one-step program, if made already (shared by a process's solvers);
    # None: ground it here when first needed.
    step: StepProgram | None = None
    # Rules added to the encodings (`planner.search.relevance.RULES`), when grounded here.
    rules: str = ""
    externals: tuple[tuple[str, int], ...] = ()  # (name, arity) of their externals

    def __post_init__(self) -> None:
        options = (*(HISTORY_FREE + CORE_GUIDED if self.history_free else ()), *self.options)
        self._plan_ctl = (
            ground(
                self.facts,
                self.horizon,
                self.context,
                skip=self.skip,
                options=options,
                rules=self.rules,
            )
            if self.program is None
            else load_preprocessed(self.program, options)
        )
        # Assumptions are passed as solver literals, looked up once: symbol
        # assumptions cost a symbol-table lookup each on every solve.
        self._fluents = _externals(self._plan_ctl, "init")
        # A program without some parts takes what stands for them as assumptions too.
        for name, arity in self.externals:
            self._fluents.update(_externals(self._plan_ctl, name, arity, by_atom=True))
        self._forbid = _externals(self._plan_ctl, "forbid")
        # The one-step program is grounded when first needed: solvers made for
        # longer horizons only plan and never list outcomes.
        self._step: StepProgram | None = None
        # What each shown symbol of a model says (`_meaning`), decoded once.
        self._shown: dict[clingo.Symbol, tuple[str, int, str]] = {}

    def _step_program(self) -> StepProgram:
        if self._step is None:
            self._step = self.step or StepProgram(self.facts, self.context, self.skip)
        return self._step

    def plan(self, state: State, forbid: Iterable[str] = ()) -> SequentialPlan | None:
        """An optimal sequential plan from `state` (outcomes chosen by the solver), or None."""
        assumptions = _assume(self._fluents, state)
        banned = set(forbid)
        assumptions.extend(lit if a in banned else -lit for a, lit in self._forbid.items())
        best: list[clingo.Symbol] = []
        above: list[bool] = [False]

        def on_model(model: clingo.Model) -> None:
            best[:] = model.symbols(shown=True)
            costs = zip(model.cost, model.priority, strict=True)
            above[0] = any(c for c, p in costs if p > STEP_PRIORITY)

        result = self._plan_ctl.solve(assumptions=assumptions, on_model=on_model)
        if not result.satisfiable:
            return None
        return self._steps(best, steps_cost_only=not above[0])

    def outcomes(self, state: State, action: Action) -> list[Successor]:
        """Every outcome of `action` in `state` and the state after it."""
        return self._step_program().outcomes(state, action)

    def _read(self, sym: clingo.Symbol) -> tuple[str, int, str]:
        return _read(self._shown, sym)

    def _steps(
        self, symbols: Sequence[clingo.Symbol], *, steps_cost_only: bool
    ) -> SequentialPlan:
        states: dict[int, set[str]] = {}
        actions: dict[int, str] = {}
        chosen: dict[int, str] = {}
        goals: set[int] = set()
        for sym in symbols:
            kind, t, text = self._read(sym)
            if kind == "h":
                states.setdefault(t, set()).add(text)
            elif kind == "occ":
                actions[t] = text
            elif kind == "out":
                chosen[t] = text
            elif kind == "goalAt":
                goals.add(t)
        steps = [
            Step(
                frozenset(states.get(t, set())),
                parse_action(actions[t]),
                chosen.get(t),
                frozenset(states.get(t + 1, set())),
                t + 1 in goals,
            )
            for t in sorted(actions)
        ]
        return SequentialPlan(steps, 0 in goals, steps_cost_only)


def _read(
    shown: dict[clingo.Symbol, tuple[str, int, str]], sym: clingo.Symbol
) -> tuple[str, int, str]:
    """What a shown symbol says (`_meaning`), read once per program."""
    meaning = shown.get(sym)
    if meaning is None:
        meaning = shown[sym] = _meaning(sym)
    return meaning


def _meaning(sym: clingo.Symbol) -> tuple[str, int, str]:
    """(predicate, time, the fluent, action or outcome label as canonical text) of a
    shown atom; ("", 0, "") for atoms the planner does not read.

    Reading a symbol's arguments through the C API is the slowest part of decoding a
    model, so `BranchSolver._read` keeps each symbol's meaning: a symbol is read
    once per solver, not once per model."""
    args = sym.arguments
    if sym.name == "goalAt":
        return "goalAt", args[0].number, ""
    if sym.name in ("h", "occ"):
        return sym.name, args[1].number, str(args[0])
    if sym.name == "out":
        return "out", args[2].number, str(args[1])
    return "", 0, ""


def _externals(
    ctl: clingo.Control, name: str, arity: int = 1, *, by_atom: bool = False
) -> dict[str, int]:
    """External atoms `name(X)` by str(X) (`by_atom`: by the atom's own text), as
    solver literals, left open.

    Open (not fixed to false) so that assumptions alone set them: an external
    fixed to false would make an assumption of true UNSAT.
    """
    out = {}
    for atom in ctl.symbolic_atoms.by_signature(name, arity):
        # (In a preprocessed program they are shown atoms standing for the
        # externals, not externals by name: `preprocessing.NAMED_EXTERNALS`.
        # Either way, every atom of the signature is one.)
        if not atom.is_fact:
            ctl.assign_external(atom.literal, None)
            out[str(atom.symbol if by_atom else atom.symbol.arguments[0])] = atom.literal
    return out


def _assume(fluents: dict[str, int], state: State) -> list[int]:
    unknown = state - fluents.keys()
    if unknown:
        raise ValueError(f"state has fluents the domain does not know: {sorted(unknown)}")
    return [lit if name in state else -lit for name, lit in fluents.items()]
