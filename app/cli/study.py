"""`tandem study STUDY.toml`: simulated participants over conditions, resumable.

Each (condition, participant) is one headless session on a simulated timeline,
run in local processes (or as Ray tasks with `--cluster`), sent back whole and
stored by this process alone (app.sessions.study_runs), tagged in the store's
`study_sessions` table (app.sessions.studies). Run again after an
interruption, the command skips what ended at a final result and runs the rest
again. It then writes `sessions.csv` (one row per counted session: its tags and
metrics), `summary.csv` (per condition and metric: n, mean, sd, 95 % interval)
and `summary.png` into `--out`.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.exit_codes import BadInput
from app.execution.events import ExecutionEvent, OutcomeSource
from app.execution.walker import Listener, Narrator
from app.sessions.store import SessionStore
from app.sessions.studies import (
    Job,
    Study,
    StudyError,
    StudySession,
    condition_summary,
    ensure_table,
    finished,
    jobs,
    load_study,
    study_sessions,
)
from app.sessions.study_figure import plot_summary
from app.sessions.study_runs import PlanKeeper, Plans, SessionRun, plan_hash, store_run
from planner.plan.model import Plan
from planner.scenario.model import Scenario
from planner.scenario.sections import Human

if TYPE_CHECKING:  # the clocks are loaded in the workers, with the executor
    from app.execution.timing import SimulatedTimeline

Row = dict[str, float | int | str | None]
TAG_COLUMNS = ("study", "condition", "scenario", "safety", "verbosity", "behaviour",
               "channel", "participant", "seed", "session_id", "result")  # fmt: skip
SUMMARY_COLUMNS = ("condition", "metric", "n", "mean", "sd", "ci95_low", "ci95_high")


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", metavar="STUDY.toml", help="the study file (docs/study.md)")
    parser.add_argument(
        "--out", help="folder for sessions.csv, summary.csv and summary.png "
        "(default: a folder named after the study, next to the study file)",
    )  # fmt: skip
    parser.add_argument("--data-dir", help="session store folder (default: $TANDEM_DATA_DIR, ...)")
    parser.add_argument(
        "--workers", type=int, default=0, help="local processes, one session each (0: all cores)"
    )
    parser.add_argument(
        "--cluster",
        metavar="auto|ray://HOST:PORT",
        help="run the sessions as Ray tasks on this cluster (they send their sessions back: "
        "only this machine needs --data-dir)",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    try:
        study = load_study(args.study)
    except StudyError as err:
        raise BadInput(str(err)) from err
    if args.workers < 0:
        raise BadInput(f"--workers {args.workers}: must be 0 or more")
    _check_scenarios(study)
    out = Path(args.out) if args.out else study.path.parent / study.name
    # The only writer of the store: the sessions run elsewhere come back here.
    with SessionStore(args.data_dir) as store:
        ensure_table(store.db)
        done = finished(study_sessions(store.db, study.name))
        todo = [j for j in jobs(study) if (j.condition.name, j.participant) not in done]
        total = len(study.conditions) * study.participants
        print(f"study {study.name}: {len(study.conditions)} conditions x "
              f"{study.participants} participants; {total - len(todo)} done, "
              f"{len(todo)} to run", file=sys.stderr)  # fmt: skip
        try:
            run_jobs(todo, store, args.cluster, args.workers)
            rows = write_results(study, store, out)
        except KeyboardInterrupt as stop:
            print("interrupted: run the same command again to go on", file=sys.stderr)
            if isinstance(stop, Abandoned):
                store.close()  # every stored session is committed; then end at once
                sys.stderr.flush()
                os._exit(130)
            return 130
    print(f"{len(rows)} sessions; wrote {out / 'sessions.csv'}, {out / 'summary.csv'} "
          f"and {out / 'summary.png'}")  # fmt: skip
    return 0 if len(rows) == total else 1


def _check_scenarios(study: Study) -> None:
    """Each scenario file read once, so a bad one is said before any session runs."""
    from planner.scenario.loading import load_scenario

    for path in {c.scenario for c in study.conditions}:
        load_scenario(path)


# -- running ----------------------------------------------------------------------------


def run_jobs(todo: Sequence[Job], store: SessionStore, cluster: str | None, workers: int) -> None:
    """Runs each job's session, as Ray tasks on `cluster`, else in local processes; this
    process alone stores each session as it comes back (app.sessions.study_runs)."""
    if not todo:
        return
    plans = Plans()
    if cluster:
        from planner.search import cluster as ray_cluster

        ray_cluster.connect(cluster)
        for run in ray_cluster.as_completed_tasks(_run_job, todo):
            _keep(store, run, plans)
        return
    processes = min(workers or mp.cpu_count(), len(todo))
    pool = mp.get_context("fork").Pool(processes, initializer=_die_with_parent)
    try:
        for run in pool.imap_unordered(_run_job, todo):
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


@dataclass
class _Channel:
    source: OutcomeSource
    listeners: list[Listener] = field(default_factory=list)
    narrator: Narrator | None = None
    close: Callable[[], None] = lambda: None


def _channel(job: Job, scenario: Scenario, plan: Plan) -> _Channel:
    """The answer channel of the job's condition, seeded by the participant."""
    from app.sources.outcomes import ExpectedSource, FallbackSource, RandomSource

    seed, kind = job.seed, job.condition.channel
    if kind == "clicks":
        return _Channel(FallbackSource(RandomSource(seed), ExpectedSource()))
    if kind == "camera":
        from app.responses.camera import camera_responses

        camera = camera_responses("sim", scenario, plan, seed)
        source = FallbackSource(camera.source, RandomSource(seed))
        return _Channel(source, list(camera.listeners), close=camera.close)
    from app.execution.narration import plan_language
    from app.responses.voice import dialogue_times, voice_responses

    # Quiet: a study prints a line per session, not each sentence heard.
    voice = voice_responses(
        "sim", plan_language(plan), RandomSource(seed), seed=seed,
        times=dialogue_times(scenario.human),
    )  # fmt: skip
    return _Channel(voice.source, narrator=voice.robot)


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


def _run_job(job: Job) -> SessionRun:
    """One participant's session in one condition, in memory: the study's process
    stores it. Its simulated clock starts at 0."""
    from app.execution.repair import Repairer
    from app.execution.retargeting import retargeter_for
    from app.execution.walker import Executor
    from app.sim.behaviours import MODELS, BehavingSource

    planned = _plan(job)
    scenario, plan = planned.scenario, planned.plan
    channel = _channel(job, scenario, plan)
    model = MODELS[job.condition.behaviour]
    source = BehavingSource(channel.source, model, job.seed, _reachable_parts(scenario))
    repairs = PlanKeeper()
    executor = Executor(
        plan,
        source,
        channel.listeners,
        narrator=channel.narrator,
        repairing=Repairer(scenario, repairs.keep).repair,
        retarget=retargeter_for(scenario, plan),
        timeline=_timeline(job, model.human(scenario.human)),
    )
    result = executor.run()
    channel.close()
    note = f"seed {job.seed}; study {job.study}: {job.condition.name} #{job.participant}"
    # A motion's path and a repair's plan are not stored with the event: not sent.
    events = tuple(replace(e, motion=None, plan=None) for e in executor.events)
    return SessionRun(job.study, job.condition.name, job.participant, note, plan,
                      planned.key, tuple(repairs.plans), events, result)  # fmt: skip


# -- results ----------------------------------------------------------------------------


def write_results(study: Study, store: SessionStore, out: Path) -> list[Row]:
    """sessions.csv, summary.csv and summary.png of the study's counted sessions."""
    counted = finished(study_sessions(store.db, study.name))
    rows: list[Row] = []
    keys: tuple[str, ...] = ()
    for job in jobs(study):
        session = counted.get((job.condition.name, job.participant))
        if session is None:
            continue
        keys, metrics = session_metrics(store.events(session.session_id), session.clock)
        rows.append({**_tags(job, session), **metrics})
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "sessions.csv", [*TAG_COLUMNS, *keys], rows)
    summary = condition_summary([c.name for c in study.conditions], rows, keys)
    _write_csv(out / "summary.csv", SUMMARY_COLUMNS, summary)
    ids = [int(i) for r in rows if isinstance(i := r["session_id"], int)]
    plot_summary([c.name for c in study.conditions], summary, keys, out / "summary.png", ids,
                 rows=rows)  # fmt: skip
    return rows


def _tags(job: Job, session: StudySession) -> Row:
    c = job.condition
    return {
        "study": job.study, "condition": c.name, "scenario": c.scenario_name,
        "safety": c.safety, "verbosity": c.verbosity, "behaviour": c.behaviour,
        "channel": c.channel, "participant": job.participant, "seed": job.seed,
        "session_id": session.session_id, "result": session.result,
    }  # fmt: skip


def session_metrics(
    events: Sequence[ExecutionEvent], clock: str | None
) -> tuple[tuple[str, ...], Row]:
    """The session's metrics (app.sessions.metrics) and their column names."""
    from app.sessions.metrics import METRIC_KEYS
    from app.sessions.metrics import session_metrics as measure

    return METRIC_KEYS, measure(events, clock=clock).row()


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[Row]) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
