"""Planning in a background thread: progress snapshots, cancel, the result or the error."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from planner.plan.model import Plan
from planner.planning import PlanningCancelled, plan_scenario
from planner.scenario.model import Scenario
from planner.search.cluster import ClusterUnavailable
from planner.search.errors import DeadEnd
from planner.search.hcp import ConditionalPlanner, Progress
from planner.search.plan_building import build_plan

JobState = Literal["idle", "planning", "done", "cancelled", "failed"]


@dataclass(frozen=True)
class JobStatus:
    state: JobState
    done: int = 0  # distinct nodes planned
    open: int = 0  # states still waiting for a solve
    seconds: float = 0.0
    message: str = ""

    @property
    def fraction(self) -> float:
        total = self.done + self.open
        return self.done / total if total else 0.0


class PlanningJob:
    """One planning run; `on_change(status)` is called from the worker thread."""

    def __init__(
        self,
        scenario: Scenario,
        on_change: Callable[[JobStatus], None],
        *,
        workers: int = 0,
        cache_dir: str | None = None,
        cluster: str | None = None,
    ) -> None:
        self.scenario = scenario
        self.on_change = on_change
        self.workers = workers
        self.cluster = cluster  # a Ray address ("auto", "ray://HOST:PORT"); None: here
        self.cache_dir = cache_dir
        self.status = JobStatus("idle")
        self.plan: Plan | None = None
        self.planner: ConditionalPlanner | None = None
        self._thread = threading.Thread(target=self._run, name="planning", daemon=True)
        self._t0 = 0.0

    def start(self) -> None:
        self._t0 = time.perf_counter()
        where = f"; joining the Ray cluster at {self.cluster}" if self.cluster else ""
        self._set(JobStatus("planning", message=f"checking geometry{where}"))
        self._thread.start()

    def cancel(self) -> None:
        if self.planner is not None:
            self.planner.cancel()

    def join(self, timeout: float | None = None) -> None:
        self._thread.join(timeout)

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _set(self, status: JobStatus) -> None:
        self.status = status
        self.on_change(status)

    def _progress(self, p: Progress) -> None:
        elapsed = time.perf_counter() - self._t0
        self._set(JobStatus("planning", p.done, p.open, elapsed, "planning"))

    def _hook(self, planner: ConditionalPlanner) -> None:
        self.planner = planner

    def _run(self) -> None:
        try:
            result = plan_scenario(
                self.scenario,
                workers=self.workers,
                progress=self._progress,
                planner_hook=self._hook,
                cache_dir=self.cache_dir,
                cluster=self.cluster,
            )
        except PlanningCancelled as err:
            self._set(JobStatus("cancelled", message=f"cancelled: {err}"))
            return
        except DeadEnd as err:
            self._set(JobStatus("failed", message=f"no plan: {err}"))
            return
        except ClusterUnavailable as err:
            self._set(JobStatus("failed", message=f"no cluster: {err}"))
            return
        except Exception as err:  # the dashboard must survive any planning failure
            self._set(JobStatus("failed", message=f"{type(err).__name__}: {err}"))
            return
        self.plan = result.plan
        elapsed = time.perf_counter() - self._t0
        nodes = int(result.plan.statistics["dag_nodes"])
        self._set(JobStatus("done", nodes, 0, elapsed, f"planned in {elapsed:.2f} s"))


def partial_plan(planner: ConditionalPlanner, scenario: Scenario) -> Plan | None:
    """The DAG planned so far as a partial plan (open states are leaves of kind "open"),
    so the tree can grow on screen while planning goes on; None if not started."""
    for _ in range(3):
        try:
            nodes = dict(planner.nodes)  # the planning thread may grow it meanwhile
            break
        except RuntimeError:
            continue
    else:
        return None
    if planner.root not in nodes:
        return None
    return build_plan(
        nodes,
        planner.root,
        scenario_name=scenario.name,
        scenario_sha256=scenario.sha256,
        facts=list(planner.problem.facts),
    )
