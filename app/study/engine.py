"""A study's sessions run: simulated participants in local processes or as Ray tasks.

Each (condition, participant) is one headless session on a simulated timeline
(`run_job`), run in local processes or as Ray tasks, sent back whole and stored
by the study's process alone (app.sessions.study_runs), tagged in the store's
`study_sessions` table (app.sessions.studies). `tandem study` drives it.
"""

from __future__ import annotations

import multiprocessing as mp
import signal
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from app.runner.session import Answering, Running, SessionRunner
from app.sessions.store import SessionStore
from app.sessions.studies import Job
from app.sessions.study_runs import PlanKeeper, Plans, SessionRun, plan_hash, store_run
from planner.plan.model import Plan
from planner.scenario.model import Scenario
from planner.scenario.sections import Human

if TYPE_CHECKING:  # the clocks are loaded in the workers
    from app.execution.timing import SimulatedTimeline


def run_jobs(todo: Sequence[Job], store: SessionStore, cluster: str | None, workers: int) -> None:
    """Runs each job's session, as Ray tasks on `cluster`, else in local processes; this
    process alone stores each session as it comes back (app.sessions.study_runs)."""
    if not todo:
        return
    plans = Plans()
    if cluster:
        from planner.search import cluster as ray_cluster

        ray_cluster.connect(cluster)
        for run in ray_cluster.as_completed_tasks(run_job, todo):
            _keep(store, run, plans)
        return
    processes = min(workers or mp.cpu_count(), len(todo))
    pool = mp.get_context("fork").Pool(processes, initializer=_die_with_parent)
    try:
        for run in pool.imap_unordered(run_job, todo):
            _keep(store, run, plans)
    except KeyboardInterrupt:
        # A Ctrl-C leaves the workers to this process (they ignore it): they end with
        # their sessions, never stored, which a resumed run runs again.
        for worker in mp.active_children():  # the pool's workers
            worker.kill()
        raise Abandoned from None
    pool.close()
    pool.join()


class Abandoned(KeyboardInterrupt):
    """A Ctrl-C ended the local workers. The pool's own teardown would wait for ever on
    a queue lock a killed worker may hold (multiprocessing's Pool), so the process
    ends without it (`os._exit`) once what it stored is committed."""


def _keep(store: SessionStore, run: SessionRun, plans: Plans) -> None:
    with _ctrl_c_held():
        session_id = store_run(store, run, plans)
    print(f"  {run.condition} participant {run.participant}: "
          f"session {session_id} {run.result}", file=sys.stderr, flush=True)  # fmt: skip


@contextmanager
def _ctrl_c_held() -> Iterator[None]:
    """A Ctrl-C waits the few milliseconds a session takes to store: no half session."""
    pressed: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda number, _: pressed.append(number))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed and callable(previous):
        previous(signal.SIGINT, None)


def _die_with_parent() -> None:
    """A worker ends when the study's process does, even by SIGKILL: nobody is left
    to store its session, which a resumed run runs again."""
    # Ctrl-C reaches the whole process group: a worker stopped in the middle of
    # handing its result back would leave the pool's queues locked.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None).prctl(pr_set_pdeathsig, signal.SIGKILL)


@dataclass(frozen=True)
class _Planned:
    scenario: Scenario
    plan: Plan
    key: str  # the plan's key in a store (app.sessions.study_runs.plan_hash)


# Plans by scenario text within one worker: a condition's participants share a plan.
_PLANS: dict[str, _Planned] = {}


def _plan(job: Job) -> _Planned:
    from planner.planning import plan_scenario
    from planner.scenario.loading import parse_scenario
    from planner.sweep import Variation, variants

    condition = job.condition
    text = condition.scenario.read_text(encoding="utf-8")
    settings = [Variation("preferences.safety", (condition.safety,)),
                Variation("preferences.verbosity", (condition.verbosity,))]  # fmt: skip
    text = variants(condition.scenario_name, text, settings)[0].text
    if text not in _PLANS:
        scenario = parse_scenario(text, str(condition.scenario))
        plan = plan_scenario(scenario, workers=1).plan
        _PLANS[text] = _Planned(scenario, plan, plan_hash(plan))
    return _PLANS[text]


def _channel(job: Job, scenario: Scenario, plan: Plan) -> Answering:
    """The answer channel of the job's condition, seeded by the participant."""
    from app.sources.outcomes import ExpectedSource, FallbackSource, RandomSource

    seed, kind = job.seed, job.condition.channel
    if kind == "clicks":
        return Answering(FallbackSource(RandomSource(seed), ExpectedSource()))
    if kind == "camera":
        from app.responses.camera import camera_responses

        return camera_responses("sim", scenario, plan, seed).answering(seed)
    from app.execution.narration import plan_language
    from app.responses.voice import Conversation, dialogue_times, voice_responses

    # Quiet: a study prints a line per session, not each sentence heard.
    conversation = Conversation(times=dialogue_times(scenario.human), seed=seed)
    voice = voice_responses("sim", plan_language(plan), RandomSource(seed),
                            conversation=conversation)  # fmt: skip
    return Answering(voice.source, narrator=voice.robot)


def _reachable_parts(scenario: Scenario) -> list[str]:
    """The parts a surprising human may pick up: within reach, and not a top (the
    table is built on it)."""
    within = {r.id for r in scenario.regions if r.human_reach}
    return [p.id for p in scenario.parts if p.region in within and p.kind != "top"]


def _timeline(job: Job, human: Human) -> SimulatedTimeline:
    """The session's simulated clock, from 0: a voice condition's questions last as
    their dialogue's audio, and the human's speech is timed on it."""
    from app.execution.timing import SimulatedTimeline

    if job.condition.channel == "voice":
        from app.sources.voice_clock import DialogueTimeline

        return DialogueTimeline(job.seed, human, origin=0.0)
    return SimulatedTimeline(job.seed, human, origin=0.0)


def run_job(job: Job) -> SessionRun:
    """One participant's session in one condition, in memory: the study's process
    stores it. Its simulated clock starts at 0."""
    from app.sim.behaviours import MODELS, BehavingSource

    planned = _plan(job)
    scenario, plan = planned.scenario, planned.plan
    channel = _channel(job, scenario, plan)
    model = MODELS[job.condition.behaviour]
    # The simulated participant acts on the channel's answers, and may surprise.
    channel.source = BehavingSource(channel.source, model, job.seed, _reachable_parts(scenario))
    repairs = PlanKeeper()
    running = Running(_timeline(job, model.human(scenario.human)))
    executor = SessionRunner(plan, scenario).executor(channel, [], running, repairs.keep)
    result = executor.run()
    channel.close()
    note = f"seed {job.seed}; study {job.study}: {job.condition.name} #{job.participant}"
    # A motion's path and a repair's plan are not stored with the event: not sent.
    events = tuple(replace(e, motion=None, plan=None) for e in executor.events)
    return SessionRun(job.study, job.condition.name, job.participant, note, plan,
                      planned.key, tuple(repairs.plans), events, result)  # fmt: skip
