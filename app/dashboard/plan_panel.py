"""The Plan panel: plan the loaded scenario here or on a Ray cluster, watch it grow.

Planning runs in a `PlanningJob` (its own thread); the panel shows its
progress, redraws the growing tree on the stage at most twice a second, shows
the finished plan with its statistics and announces it (`Planned`). Planning
again drops the shown plan, so nobody executes it meanwhile; while an
execution runs nobody may plan. The lines and rules are plain functions
below, apart from the widgets. See stage.py for the panel pattern.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import viser

from app.dashboard.node_details import stats_html
from app.dashboard.planning_job import JobStatus, PlanningJob, partial_plan
from app.dashboard.stage import (
    Events,
    ExecutionFinished,
    ExecutionStarted,
    PlanChanged,
    Planned,
    ScenarioChanged,
    Stage,
)
from app.dashboard.widgets import show
from planner.scenario.model import Scenario

# The choices of "Solve on".
HERE = "this machine"
RAY = "a Ray cluster"
LIVE_REDRAW_S = 0.5  # at most two redraws of the growing tree per second
# A redraw of a large growing plan takes time from the planner (the GIL): at
# most this share of the time planning goes to it (U10: ~0.1 s a redraw).
LIVE_SHARE = 0.05
STATUS_EVERY_S = 0.1  # the progress line, at most ten times a second


@dataclass(frozen=True)
class PlanSettings:
    """How the page plans: worker processes, the solver's cache, and the Ray
    address "Solve on" starts with (None: this machine)."""

    workers: int = 0
    cache_dir: str | None = None
    cluster: str | None = None


def cluster_address(solve_on: str, address: str) -> str | None:
    """The Ray address the next plan is solved on; None: on this machine."""
    if solve_on != RAY:
        return None
    return address.strip() or "auto"


def progress_percent(status: JobStatus) -> float:
    return 100.0 * (status.fraction if status.state == "planning" else 1.0)


def status_line(status: JobStatus) -> str:
    if status.state == "planning":
        return f"Planning: {status.done} nodes done, {status.open} open ({status.seconds:.1f} s)"
    return status.message


def scenario_line(scenario: Scenario, edited: bool) -> str:
    if edited:
        return "Scenario changed: not planned yet, press **Plan**."
    return f"Scenario **{scenario.name}** ({len(scenario.parts)} parts): not planned yet."


def plan_refused(executing: bool, planning: bool) -> bool:
    """The "Plan" button is off while an execution runs or a plan is being made."""
    return executing or planning


class LiveRedraw:
    """When the growing tree is drawn again: at most once per `every_s`, and
    rarer as a redraw costs more (`spent`), so that redraws take no more than
    `share` of the time."""

    def __init__(self, every_s: float = LIVE_REDRAW_S, share: float = LIVE_SHARE) -> None:
        self.every_s = every_s
        self.share = share
        self.cost = 0.0
        self.last = 0.0

    def due(self, now: float) -> bool:
        if now - self.last <= max(self.every_s, self.cost / self.share):
            return False
        self.last = now
        return True

    def spent(self, seconds: float) -> None:
        """What the last redraw took."""
        self.cost = seconds


class PlanPanel:
    def __init__(
        self, gui: viser.GuiApi, stage: Stage, events: Events, settings: PlanSettings
    ) -> None:
        self.stage = stage
        self.events = events
        self.settings = settings
        self.job: PlanningJob | None = None
        self.executing = False
        self._live = LiveRedraw()
        self._status_tick = LiveRedraw(STATUS_EVERY_S)
        with gui.add_folder("Plan"):
            # The button first: a new page shows it without scrolling, at 1280×800 too.
            self.plan_button = gui.add_button("Plan", color="green")
            self.plan_button.on_click(lambda _: self.start_planning())
            self.cancel_button = gui.add_button("Cancel", disabled=True)
            self.cancel_button.on_click(lambda _: self.job.cancel() if self.job else None)
            self.progress = gui.add_progress_bar(0.0)
            self.status = gui.add_markdown("Not planned yet.")
            with gui.add_folder("Statistics", expand_by_default=False):
                self.stats = gui.add_html("")
            # Where branches are solved: this machine's processes, or Ray actors
            # (`tandem plan --cluster`); the address is kept while "this machine".
            self.solve_on = gui.add_dropdown(
                "Solve on",
                [HERE, RAY],
                initial_value=RAY if settings.cluster else HERE,
                hint="Ray needs tandem[cluster]; auto joins this machine's cluster or starts one",
            )
            self.ray_address = gui.add_text(
                "Ray address",
                settings.cluster or "auto",
                disabled=not settings.cluster,
                hint="auto, or ray://HOST:PORT of a cluster's head",
            )
            self.solve_on.on_update(
                lambda _: setattr(self.ray_address, "disabled", self.solve_on.value != RAY)
            )
        events.subscribe(ScenarioChanged, self._scenario_changed)
        events.subscribe(PlanChanged, self._plan_changed)
        events.subscribe(ExecutionStarted, lambda _: self._lock(True))
        events.subscribe(ExecutionFinished, lambda _: self._lock(False))

    @property
    def planning(self) -> bool:
        return self.job is not None and self.job.running

    @property
    def cluster(self) -> str | None:
        """The Ray address the next plan is solved on; None: on this machine."""
        return cluster_address(self.solve_on.value, self.ray_address.value)

    def start_planning(self) -> None:
        scenario = self.stage.current_scenario()
        if scenario is None or self.executing or self.planning:
            return
        self.plan_button.disabled = True
        self.cancel_button.disabled = False
        self.stats.content = ""
        self._live = LiveRedraw()
        self.stage.drop_plan()
        self.job = PlanningJob(
            scenario,
            self._job_changed,
            workers=self.settings.workers,
            cache_dir=self.settings.cache_dir,
            cluster=self.cluster,
        )
        self.job.start()

    def _job_changed(self, status: JobStatus) -> None:
        """Each status of the job (its thread, or the caller's for the first)."""
        job = self.job
        if status.state == "planning":
            now = time.perf_counter()
            if self._status_tick.due(now):
                show(self.progress, progress_percent(status))
                self.status.content = status_line(status)
            if job is not None and job.planner is not None and self._live.due(now):
                partial = partial_plan(job.planner, job.scenario)
                if partial is not None:
                    self.stage.show_growing(partial)
                self._live.spent(time.perf_counter() - now)
            return
        show(self.progress, progress_percent(status))
        self.status.content = status_line(status)
        self.plan_button.disabled = plan_refused(self.executing, planning=False)
        self.cancel_button.disabled = True
        # A plan of a scenario no longer loaded is never shown.
        current = job is not None and job.scenario is self.stage.current_scenario()
        if status.state == "done" and job is not None and job.plan is not None and current:
            self.stage.show_plan(job.plan)
            self.events.publish(Planned(job.plan))

    def _scenario_changed(self, message: ScenarioChanged) -> None:
        if self.job is not None and self.job.running:
            self.job.cancel()  # it plans the scenario before
        show(self.progress, 0.0)
        self.status.content = scenario_line(message.scenario, message.edited)

    def _plan_changed(self, message: PlanChanged) -> None:
        self.stats.content = stats_html(message.plan) if message.plan is not None else ""

    def _lock(self, locked: bool) -> None:
        """While an execution runs nobody may plan again under it."""
        self.executing = locked
        self.solve_on.disabled = locked
        self.plan_button.disabled = plan_refused(locked, self.planning)

    def close(self) -> None:
        if self.job is not None:
            self.job.cancel()
