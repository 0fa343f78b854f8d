"""Studies: simulated participants run over conditions, and their sessions' tags.

A study file (TOML, docs/study.md) names the study, its participants and the
conditions' factors; the conditions are every combination of the factors'
values (scenario x safety x verbosity x behaviour x channel), and each
participant runs once in each condition, seeded by its number, so the same
participant meets every condition (a within-subject design).

Each session a study runs is tagged in the session store's table
`study_sessions(session_id, study, condition, participant)`, created when a
store is opened for a study (so an older store gets it). The study's process
writes a session whole once it has run (app.sessions.study_runs) and tags it
as it starts writing, so a run killed half-way leaves that session tagged and
marked "interrupted" by the store: such a session is stale, run again, and
not counted; one that ended at a final result is not run again.
"""

from __future__ import annotations

import itertools
import math
import re
import statistics
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, cast, get_args

from sqlite_utils import Database

from app.execution.events import Result

# The figure's own module; named here too, where the dashboard's review finds them.
from app.sessions.study_figure import FIGURE_METRICS as FIGURE_METRICS
from app.sessions.study_figure import figure_metrics as figure_metrics
from app.sessions.study_figure import plot_summary as plot_summary

Channel = Literal["clicks", "camera", "voice"]
CHANNELS: tuple[Channel, ...] = get_args(Channel)
Safety = Literal["relaxed", "normal", "strict"]
Verbosity = Literal["terse", "normal", "chatty"]
# The simulated participants' behaviours, modelled in app.sim.behaviours.
Behaviour = Literal["cooperative", "hesitant", "surprising"]
BEHAVIOURS: tuple[Behaviour, ...] = get_args(Behaviour)
# A session that ended so is done; "interrupted" (or still open) is run again.
FINAL_RESULTS: tuple[Result, ...] = ("goal", "aborted", "dead-end")

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
_STUDY_KEYS = {"name", "participants", "seed"}
_FACTORS: dict[str, tuple[str, ...] | None] = {
    "scenario": None,  # any scenario file
    "safety": get_args(Safety),
    "verbosity": get_args(Verbosity),
    "behaviour": BEHAVIOURS,
    "channel": CHANNELS,
}


class StudyError(ValueError):
    """A study file that cannot be used; `str()` is one line naming the file."""


@dataclass(frozen=True)
class Condition:
    """One combination of the factors' values."""

    scenario: Path  # the scenario file
    scenario_name: str  # its stem, for the condition's name
    safety: Safety
    verbosity: Verbosity
    behaviour: Behaviour
    channel: Channel

    @property
    def name(self) -> str:
        return "/".join(
            (self.scenario_name, self.safety, self.verbosity, self.behaviour, self.channel)
        )


@dataclass(frozen=True)
class Study:
    name: str
    participants: int
    seed: int  # participant p (1-based) is seeded `seed + p - 1`
    conditions: tuple[Condition, ...]
    path: Path

    def participant_seed(self, participant: int) -> int:
        return self.seed + participant - 1


@dataclass(frozen=True)
class Job:
    """One participant in one condition: one session."""

    study: str
    condition: Condition
    participant: int
    seed: int


def jobs(study: Study) -> list[Job]:
    """Every (condition, participant), conditions in the file's order."""
    return [
        Job(study.name, c, p, study.participant_seed(p))
        for c in study.conditions
        for p in range(1, study.participants + 1)
    ]


def load_study(path: str | Path) -> Study:
    """Reads and checks a study file; `StudyError` with one line if it is not usable."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise StudyError(f"{path}: cannot read: {err.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise StudyError(f"{path}: not TOML: {err}") from None
    unknown = set(doc) - {"study", "conditions"}
    if unknown:
        raise StudyError(f"{path}: unknown table(s) {', '.join(sorted(unknown))}; "
                         "a study has [study] and [conditions]")  # fmt: skip
    head = _table(doc, "study", path)
    _no_unknown(head, _STUDY_KEYS, "[study]", path)
    name = head.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise StudyError(f"{path}: [study] name: a word of letters, digits, '-', '_' or '.'")
    participants = _integer(head, "participants", None, path, minimum=1)
    seed = _integer(head, "seed", 1, path, minimum=0)
    factors = _table(doc, "conditions", path)
    _no_unknown(factors, set(_FACTORS), "[conditions]", path)
    values = {key: _values(factors, key, allowed, path) for key, allowed in _FACTORS.items()}
    scenarios = [_scenario_file(s, path) for s in values["scenario"]]
    # The values were checked against the Literals above: the casts only say so.
    conditions = tuple(
        Condition(
            scenario,
            scenario.stem,
            cast(Safety, safety),
            cast(Verbosity, verbosity),
            cast(Behaviour, behaviour),
            cast(Channel, channel),
        )  # fmt: skip
        for scenario in scenarios
        for safety, verbosity, behaviour, channel in itertools.product(
            *(values[k] for k in ("safety", "verbosity", "behaviour", "channel"))
        )
    )
    names = [c.name for c in conditions]
    if len(set(names)) != len(names):
        raise StudyError(f"{path}: [conditions] scenario: two scenario files share a name")
    return Study(name, participants, seed, conditions, path)


def _table(doc: dict[str, Any], key: str, path: Path) -> dict[str, Any]:
    table = doc.get(key)
    if not isinstance(table, dict):
        raise StudyError(f"{path}: missing the [{key}] table")
    return table


def _no_unknown(table: dict[str, Any], known: set[str], where: str, path: Path) -> None:
    unknown = sorted(set(table) - known)
    if unknown:
        raise StudyError(
            f"{path}: {where} {unknown[0]}: unknown key (known: {', '.join(sorted(known))})"
        )


def _integer(table: dict[str, Any], key: str, default: int | None, path: Path, minimum: int) -> int:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise StudyError(f"{path}: [study] {key}: a whole number of {minimum} or more")
    return value


def _values(
    table: dict[str, Any], key: str, allowed: tuple[str, ...] | None, path: Path
) -> list[str]:
    """The factor's values: a string or a list of strings; the defaults when absent."""
    value = table.get(key)
    if value is None:
        if allowed is None:
            raise StudyError(f"{path}: [conditions] scenario: missing (a scenario file or a list)")
        return [{"behaviour": "cooperative", "channel": "clicks"}.get(key, "normal")]
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items or not all(isinstance(v, str) for v in items):
        raise StudyError(f"{path}: [conditions] {key}: a string or a non-empty list of strings")
    if len(set(items)) != len(items):
        raise StudyError(f"{path}: [conditions] {key}: a value is repeated")
    for item in items:
        if allowed is not None and item not in allowed:
            raise StudyError(
                f"{path}: [conditions] {key}: '{item}' is not one of {', '.join(allowed)}"
            )
    return list(items)


def _scenario_file(text: str, study_path: Path) -> Path:
    """A scenario named relative to the study file, else as `tandem execute` finds it."""
    from planner.resources import find_scenario

    beside = study_path.parent / text
    found = beside if beside.is_file() else find_scenario(text)
    if not found.is_file():
        raise StudyError(f"{study_path}: [conditions] scenario: no scenario file '{text}'")
    return found.resolve()


# -- the store's table ----------------------------------------------------------------


@dataclass(frozen=True)
class StudySession:
    """A tagged session, with how it ended (None while it runs) and its clock."""

    session_id: int
    condition: str
    participant: int
    result: Result | None
    started: float
    clock: str | None = None


def ensure_table(db: Database) -> None:
    """Creates `study_sessions` and its index if the store has not got them."""
    db.execute(
        "create table if not exists study_sessions (session_id integer primary key "
        "references sessions(id), study text not null, condition text not null, "
        "participant integer not null)"
    )
    db.execute(
        "create index if not exists idx_study_sessions_study "
        "on study_sessions (study, condition, participant)"
    )


def tag(db: Database, session_id: int, study: str, condition: str, participant: int) -> None:
    with db.conn:
        db.conn.execute(
            "insert into study_sessions (session_id, study, condition, participant) "
            "values (?, ?, ?, ?)",
            [session_id, study, condition, participant],
        )


def study_sessions(db: Database, study: str) -> list[StudySession]:
    """The study's tagged sessions, oldest first (stale ones included)."""
    # A store opened read-only may be older than sessions' clocks: none then.
    columns = {row[1] for row in db.execute("pragma table_info(sessions)")}
    clock = "s.clock" if "clock" in columns else "null"
    rows = db.execute(
        f"select t.session_id, t.condition, t.participant, s.result, s.started, {clock} "
        "from study_sessions t join sessions s on s.id = t.session_id "
        "where t.study = ? order by s.started, s.id",
        [study],
    ).fetchall()
    return [StudySession(*row) for row in rows]


def finished(sessions: Iterable[StudySession]) -> dict[tuple[str, int], StudySession]:
    """The counted session of each (condition, participant): the latest at a final result."""
    out: dict[tuple[str, int], StudySession] = {}
    for session in sessions:
        if session.result in FINAL_RESULTS:
            out[(session.condition, session.participant)] = session
    return out


# -- summaries ------------------------------------------------------------------------

# Student's t, two-sided 95 %, by degrees of freedom (1..30); 1.96 beyond.
_T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
        2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
        2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042)  # fmt: skip


@dataclass(frozen=True)
class Summary:
    """A metric over a condition's sessions: mean, sd and the t-based 95 % interval."""

    n: int
    mean: float | None
    sd: float | None
    low: float | None
    high: float | None


def summarise(values: Sequence[float | int | None]) -> Summary:
    """The summary of the values present (None ones are left out)."""
    xs = [float(v) for v in values if v is not None and not math.isnan(float(v))]
    if not xs:
        return Summary(0, None, None, None, None)
    mean = statistics.fmean(xs)
    if len(xs) < 2:
        return Summary(1, mean, None, None, None)
    sd = statistics.stdev(xs)
    df = len(xs) - 1
    half = (_T95[df - 1] if df <= len(_T95) else 1.96) * sd / math.sqrt(len(xs))
    return Summary(len(xs), mean, sd, mean - half, mean + half)


# -- a study read back from the store (the dashboard's review) -------------------------

Row = dict[str, float | int | str | None]
SUMMARY_KEYS = ("condition", "metric", "n", "mean", "sd", "ci95_low", "ci95_high")


def study_names(db: Database) -> list[str]:
    """The studies that tagged sessions in this store, by name."""
    ensure_table(db)
    return [row[0] for row in db.execute("select distinct study from study_sessions "
                                         "order by study").fetchall()]  # fmt: skip


def condition_summary(
    conditions: Sequence[str], rows: Sequence[Row], keys: Sequence[str]
) -> list[Row]:
    """Per condition (each row's "condition") and numeric metric among `keys`: n,
    mean, sd and the 95 % interval, keyed by `SUMMARY_KEYS`."""
    out: list[Row] = []
    for condition in conditions:
        mine = [r for r in rows if r["condition"] == condition]
        for key in keys:
            values = [v for r in mine if isinstance(v := r.get(key), int | float)]
            if not values and any(r.get(key) is not None for r in mine):
                continue  # a column of words: no mean
            s = summarise(values)
            out.append({"condition": condition, "metric": key, "n": s.n,
                        **{k: _round(v) for k, v in (("mean", s.mean), ("sd", s.sd),
                           ("ci95_low", s.low), ("ci95_high", s.high))}})  # fmt: skip
    return out


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 4)
