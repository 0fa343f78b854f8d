"""`tandem study`: participants over conditions, killed and resumed, one row per session."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from PIL import Image

from app.execution.surprises import HumanPutDown, HumanTook
from app.sessions.store import SessionStore
from app.sessions.studies import (
    FINAL_RESULTS,
    StudyError,
    ensure_table,
    jobs,
    load_study,
    study_sessions,
    summarise,
)
from app.sim.behaviours import MODELS, BehavingSource
from app.sources.outcomes import RandomSource
from planner.scenario.model import Human
from tests.plan_fixtures import ROOT, default_plan, tandem, tandem_command

EXAMPLE = ROOT / "static" / "studies" / "example.toml"


def _counted(data: Path) -> list[tuple[int, str, int, str | None]]:
    with SessionStore(data) as store:
        ensure_table(store.db)
        tagged = study_sessions(store.db, "example")
    return [(s.session_id, s.condition, s.participant, s.result) for s in tagged]


def _children(pid: int) -> list[int]:
    """The processes `pid` started (Linux: its threads' children)."""
    tasks = Path(f"/proc/{pid}/task")
    return [int(c) for t in tasks.iterdir() for c in (t / "children").read_text().split()]


def _wait_gone(pids: list[int]) -> None:
    """Until the killed study's workers are gone (they die with it)."""
    deadline = time.monotonic() + 20
    for pid in pids:
        while time.monotonic() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.05)
        else:
            pytest.fail(f"worker {pid} outlived the killed study")


def _default_ctrl_c() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _stop_after_first_session(
    data: Path, out: Path, how: signal.Signals, study_file: Path = EXAMPLE
) -> tuple[int, list[int]]:
    """Sends `how` to the study (Ctrl-C: to its process group, as a terminal does) once
    it stored a session; its exit code and its workers."""
    args = [*tandem_command(), "study", str(study_file), "--data-dir", str(data),
            "--out", str(out), "--workers", "1"]  # fmt: skip
    # Started as a terminal's shell starts a command, with Ctrl-C's default action: a
    # test run started in the background (`make test &`) ignores SIGINT, which its
    # children would inherit, and the study would never see the Ctrl-C.
    study = subprocess.Popen(args, cwd=ROOT, stderr=subprocess.PIPE, text=True,
                             start_new_session=True, preexec_fn=_default_ctrl_c)  # fmt: skip
    assert study.stderr is not None
    for line in study.stderr:
        if " goal" in line or " aborted" in line or " dead-end" in line:
            break
    workers = _children(study.pid)
    if how == signal.SIGINT:
        os.killpg(study.pid, how)
    else:
        study.send_signal(how)
    code = study.wait(timeout=30)
    study.stderr.close()
    return code, workers


def _caught_midway(
    tmp_path: Path, how: signal.Signals, total: int, study_file: Path = EXAMPLE
) -> tuple[Path, Path, int]:
    """A study stopped by `how` after its first session and before its last: its data
    and out folders, and its exit code. A session takes tens of milliseconds, so on a
    loaded machine the study may finish before the signal arrives: that run proves
    nothing, and a fresh one is started (at most five)."""
    for attempt in range(5):
        data, out = tmp_path / f"data{attempt}", tmp_path / f"out{attempt}"
        code, workers = _stop_after_first_session(data, out, how, study_file)
        # Nothing is left to store a session behind the resumed run: the one writer
        # is gone, and its workers die with it.
        assert workers
        _wait_gone(workers)
        finals = [s for s in _counted(data) if s[3] in FINAL_RESULTS]
        assert finals, "the signal came after the first session: it is stored"
        if len(finals) < total:
            return data, out, code
    pytest.fail(f"the study ran all {total} sessions before the signal, five times")


def test_a_study_killed_midway_resumes_to_one_session_each(tmp_path: Path) -> None:
    data, out, _ = _caught_midway(tmp_path, signal.SIGKILL, 6)
    before = _counted(data)
    finals = [s for s in before if s[3] in FINAL_RESULTS]
    assert 1 <= len(finals) < 6, "killed midway: some sessions done, not all"
    assert not (out / "sessions.csv").exists()

    resumed = tandem("study", str(EXAMPLE), "--data-dir", str(data), "--out", str(out))
    assert resumed.returncode == 0, resumed.stderr
    assert f"{len(finals)} done, {6 - len(finals)} to run" in resumed.stderr
    after = _counted(data)
    counted = [s for s in after if s[3] in FINAL_RESULTS]
    assert len(counted) == 6
    assert {(c, p) for _, c, p, _ in counted} == {
        (j.condition.name, j.participant) for j in jobs(load_study(EXAMPLE))
    }
    # What was done before is kept; the stale one is marked, not counted.
    assert set(finals) <= set(counted)
    assert all(s[3] == "interrupted" for s in after if s not in counted)

    with (out / "sessions.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert sorted(int(r["session_id"]) for r in rows) == sorted(s[0] for s in counted)
    assert {r["behaviour"] for r in rows} == {"cooperative", "hesitant"}
    assert all(float(r["task_s"]) > 0 and r["timed"] == "True" for r in rows)
    with (out / "summary.csv").open() as f:
        summary = [r for r in csv.DictReader(f) if r["metric"] == "task_s"]
    for line in summary:
        mine = [float(r["task_s"]) for r in rows if r["condition"] == line["condition"]]
        assert int(line["n"]) == 3
        assert float(line["mean"]) == pytest.approx(sum(mine) / 3, abs=1e-3)
        assert float(line["ci95_low"]) <= float(line["mean"]) <= float(line["ci95_high"])
    figure = Image.open(out / "summary.png")
    assert figure.format == "PNG" and figure.width > 300
    assert figure.info["Sessions"] == ",".join(str(s[0]) for s in sorted(counted))

    again = tandem("study", str(EXAMPLE), "--data-dir", str(data), "--out", str(out))
    assert again.returncode == 0, again.stderr
    assert "6 done, 0 to run" in again.stderr
    assert len(_counted(data)) == len(after)


def test_ctrl_c_stops_a_study_at_once_keeping_only_whole_sessions(tmp_path: Path) -> None:
    # The example with more participants: still running when Ctrl-C comes.
    total = 2 * 12
    study = tmp_path / "example.toml"
    text = EXAMPLE.read_text().replace("participants = 3", f"participants = {total // 2}")
    study.write_text(text.replace('"../scenarios/', f'"{EXAMPLE.parent.parent}/scenarios/'))
    data, out, code = _caught_midway(tmp_path, signal.SIGINT, total, study)
    assert code == 130
    # The sessions under way were never stored: what is there ended at a final result.
    before = _counted(data)
    assert 1 <= len(before) < total and all(s[3] in FINAL_RESULTS for s in before)
    resumed = tandem("study", str(study), "--data-dir", str(data), "--out", str(out))
    assert resumed.returncode == 0, resumed.stderr
    assert f"{len(before)} done, {total - len(before)} to run" in resumed.stderr
    assert len(_counted(data)) == total


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ('[study]\nname = "s"\nparticipants = 0\n[conditions]\nscenario = "default.toml"\n',
         "[study] participants: a whole number of 1 or more"),
        ('[study]\nname = "s"\nparticipants = 2\n[conditions]\nscenario = "default.toml"\n'
         'behaviour = ["lazy"]\n',
         "[conditions] behaviour: 'lazy' is not one of cooperative, hesitant, surprising"),
        ('[study]\nname = "s"\nparticipants = 2\n[conditions]\nchannel = "clicks"\n',
         "[conditions] scenario: missing"),
        ("[study\n", "not TOML"),
    ],
)  # fmt: skip
def test_a_bad_study_file_is_one_line_and_exit_2(tmp_path: Path, text: str, said: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    result = tandem("study", str(path), "--data-dir", str(tmp_path / "data"))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and said in result.stderr, result.stderr
    assert not (tmp_path / "data").exists() or not list((tmp_path / "data").iterdir())


def test_conditions_cross_every_factor_and_participants_keep_their_seed(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(
        '[study]\nname = "s"\nparticipants = 2\nseed = 10\n[conditions]\n'
        'scenario = "default.toml"\nsafety = ["normal", "strict"]\n'
        'behaviour = ["cooperative", "surprising"]\nchannel = ["clicks", "voice"]\n',
        encoding="utf-8",
    )
    study = load_study(path)
    assert len(study.conditions) == 8
    assert study.conditions[0].name == "default/normal/normal/cooperative/clicks"
    assert {(j.participant, j.seed) for j in jobs(study)} == {(1, 10), (2, 11)}
    with pytest.raises(StudyError, match="unknown key"):
        path.write_text('[study]\nname = "s"\nparticipants = 1\nwho = 1\n[conditions]\n')
        load_study(path)


def test_the_summary_is_mean_sd_and_the_t_interval() -> None:
    s = summarise([1.0, 2.0, 3.0, None])
    assert (s.n, s.mean, s.sd) == (3, 2.0, 1.0)
    # t(2) at 95 % is 4.303: 2 +- 4.303 * 1 / sqrt(3).
    assert s.low == pytest.approx(2 - 2.4843, abs=1e-3)
    assert s.high == pytest.approx(2 + 2.4843, abs=1e-3)
    assert summarise([5]).sd is None and summarise([]).n == 0


def test_a_hesitant_human_is_slower_and_declines_sometimes() -> None:
    human = MODELS["hesitant"].human(Human())
    assert human.react_s == 2 * Human().react_s and human.answer_s == 2.5 * Human().answer_s
    plan = default_plan()
    questions = [(i, n) for i, n in plan.nodes.items() if n.kind == "communication" and
                 len(n.outcomes) > 1 and n.expected in n.outcomes]  # fmt: skip
    assert questions
    declined = 0
    for seed in range(40):
        source = BehavingSource(RandomSource(seed), MODELS["hesitant"], seed)
        node_id, node = questions[0]
        outcome = source.choose(node_id, node, node.outcomes)
        assert outcome is not None and outcome.label in node.outcomes
        declined += source.declines
        if source.declines:
            assert outcome.label != node.expected
    assert 0 < declined < 40


def test_a_surprising_human_does_only_what_the_state_allows() -> None:
    plan = default_plan()
    sensing = [(i, n) for i, n in plan.nodes.items() if n.kind == "sensing"]
    surprises = 0
    for seed in range(30):
        source = BehavingSource(RandomSource(seed), MODELS["surprising"], seed, ["leg2", "foot2"])
        for node_id, node in sensing:
            outcome = source.choose(node_id, node, node.outcomes)
            assert outcome is not None
            if outcome.surprise is not None:
                assert isinstance(outcome.surprise, HumanTook | HumanPutDown)
                outcome.surprise.apply(frozenset(node.state))  # no SurpriseError
                surprises += 1
        assert source.surprises <= MODELS["surprising"].max_surprises
    assert surprises > 0


def test_the_example_study_file_is_valid() -> None:
    study = load_study(EXAMPLE)
    assert (len(study.conditions), study.participants) == (2, 3)
    assert all(c.scenario.is_file() for c in study.conditions)
