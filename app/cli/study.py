"""`tandem study STUDY.toml`: simulated participants over conditions, resumable.

Each (condition, participant) is one headless session on a simulated timeline,
run in local processes (or as Ray tasks with `--cluster`) and tagged in the
store's `study_sessions` table (app.sessions.studies). Run again after an
interruption, the command skips what ended at a final result and runs the rest
again. It then writes `sessions.csv` (one row per counted session: its tags and
metrics), `summary.csv` (per condition and metric: n, mean, sd, 95 % interval)
and `summary.png` into `--out`.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import signal
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from app.cli.exit_codes import BadInput
from app.execution.events import ExecutionEvent, OutcomeSource, Result
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
    plot_summary,
    study_sessions,
    tag,
)
from planner.plan.model import Plan
from planner.scenario.model import Scenario

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
        help="run the sessions as Ray tasks on this cluster (its nodes must see --data-dir)",
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
    with SessionStore(args.data_dir) as store:
        ensure_table(store.db)
        done = finished(study_sessions(store.db, study.name))
        data_dir = str(store.data_dir)
    todo = [j for j in jobs(study) if (j.condition.name, j.participant) not in done]
    total = len(study.conditions) * study.participants
    print(f"study {study.name}: {len(study.conditions)} conditions x "
          f"{study.participants} participants; {total - len(todo)} done, {len(todo)} to run",
          file=sys.stderr)  # fmt: skip
    try:
        run_jobs(todo, data_dir, args.cluster, args.workers)
    except KeyboardInterrupt:
        print("interrupted: run the same command again to go on", file=sys.stderr)
        return 130
    rows = write_results(study, data_dir, out)
    print(f"{len(rows)} sessions; wrote {out / 'sessions.csv'}, {out / 'summary.csv'} "
          f"and {out / 'summary.png'}")  # fmt: skip
    return 0 if len(rows) == total else 1


def _check_scenarios(study: Study) -> None:
    """Each scenario file read once, so a bad one is said before any session runs."""
    from planner.scenario.loading import load_scenario

    for path in {c.scenario for c in study.conditions}:
        load_scenario(path)


# -- running ----------------------------------------------------------------------------


@dataclass(frozen=True)
class JobDone:
    job: Job
    session_id: int
    result: Result


def run_jobs(todo: Sequence[Job], data_dir: str, cluster: str | None, workers: int) -> None:
    """Runs each job's session: as Ray tasks on `cluster`, else in local processes."""
    if not todo:
        return
    work = [(job, data_dir) for job in todo]
    if cluster:
        from planner.search import cluster as ray_cluster

        ray_cluster.connect(cluster)
        for done in ray_cluster.map_tasks(_run_job, work):
            _report(done)
        return
    with ProcessPoolExecutor(
        max_workers=min(workers or mp.cpu_count(), len(todo)),
        mp_context=mp.get_context("fork"),
        initializer=_die_with_parent,
    ) as pool:
        futures = [pool.submit(_run_job, item) for item in work]
        try:
            for future in as_completed(futures):
                _report(future.result())
        except KeyboardInterrupt:
            # The running sessions stop on the same Ctrl-C; the waiting ones never start.
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _report(done: JobDone) -> None:
    print(f"  {done.job.condition.name} participant {done.job.participant}: "
          f"session {done.session_id} {done.result}", file=sys.stderr, flush=True)  # fmt: skip


def _die_with_parent() -> None:
    """A worker ends when the study's process does, even by SIGKILL: its session is then
    left to be marked interrupted, never finished behind a run that resumes it."""
    # Ctrl-C reaches the whole process group: the worker's executor stops on it.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if sys.platform.startswith("linux"):
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None).prctl(pr_set_pdeathsig, signal.SIGKILL)


# Plans by scenario text within one worker: a condition's participants share a plan.
_PLANS: dict[str, tuple[Scenario, Plan]] = {}


def _plan(job: Job) -> tuple[Scenario, Plan]:
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
        _PLANS[text] = (scenario, plan_scenario(scenario, workers=1).plan)
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


def _run_job(item: tuple[Job, str]) -> JobDone:
    """One participant's session in one condition, tagged as it starts."""
    from app.execution.repair import Repairer
    from app.execution.retargeting import retargeter_for
    from app.execution.timing import SimulatedTimeline
    from app.execution.walker import Executor
    from app.sim.behaviours import MODELS, BehavingSource

    job, data_dir = item
    scenario, plan = _plan(job)
    channel = _channel(job, scenario, plan)
    model = MODELS[job.condition.behaviour]
    source = BehavingSource(channel.source, model, job.seed, _reachable_parts(scenario))
    note = f"seed {job.seed}; study {job.study}: {job.condition.name} #{job.participant}"
    with SessionStore(data_dir) as store:
        ensure_table(store.db)
        session_id = store.start(plan, note=note, clock="simulated")
        tag(store.db, session_id, job.study, job.condition.name, job.participant)
        executor = Executor(
            plan,
            source,
            [store.recorder(session_id), *channel.listeners],
            narrator=channel.narrator,
            repairing=Repairer(scenario, store.add_plan).repair,
            retarget=retargeter_for(scenario, plan),
            timeline=SimulatedTimeline(job.seed, model.human(scenario.human)),
        )
        result: Result
        try:
            result = executor.run()
        except KeyboardInterrupt:
            result = "interrupted"
        store.finish(session_id, result, ended=executor.timeline.now())
    channel.close()
    return JobDone(job, session_id, result)


# -- results ----------------------------------------------------------------------------


def write_results(study: Study, data_dir: str, out: Path) -> list[Row]:
    """sessions.csv, summary.csv and summary.png of the study's counted sessions."""
    with SessionStore(data_dir) as store:
        ensure_table(store.db)
        counted = finished(study_sessions(store.db, study.name))
        rows: list[Row] = []
        keys: tuple[str, ...] = ()
        for job in jobs(study):
            session = counted.get((job.condition.name, job.participant))
            if session is None:
                continue
            keys, metrics = session_metrics(store.events(session.session_id))
            rows.append({**_tags(job, session), **metrics})
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "sessions.csv", [*TAG_COLUMNS, *keys], rows)
    summary = condition_summary([c.name for c in study.conditions], rows, keys)
    _write_csv(out / "summary.csv", SUMMARY_COLUMNS, summary)
    ids = [int(i) for r in rows if isinstance(i := r["session_id"], int)]
    plot_summary([c.name for c in study.conditions], summary, keys, out / "summary.png", ids)
    return rows


def _tags(job: Job, session: StudySession) -> Row:
    c = job.condition
    return {
        "study": job.study, "condition": c.name, "scenario": c.scenario_name,
        "safety": c.safety, "verbosity": c.verbosity, "behaviour": c.behaviour,
        "channel": c.channel, "participant": job.participant, "seed": job.seed,
        "session_id": session.session_id, "result": session.result,
    }  # fmt: skip


def session_metrics(events: Sequence[ExecutionEvent]) -> tuple[tuple[str, ...], Row]:
    """The session's metrics (app.sessions.metrics) and their column names."""
    from app.sessions.metrics import METRIC_KEYS
    from app.sessions.metrics import session_metrics as measure

    return METRIC_KEYS, measure(events).row()


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[Row]) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
