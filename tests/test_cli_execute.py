"""`tandem execute` and `tandem sessions`, run as real processes."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from app.execution.events import is_step
from app.sessions.export import exported_event
from app.sessions.store import DB_NAME, SessionStore
from planner.plan.model import Plan
from tests.plan_fixtures import ROOT, default_plan, paper_plan, tandem, tandem_command
from tests.plan_paths import is_plan_path


@pytest.fixture(scope="module")
def plan_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plans") / "default.json"
    path.write_text(json.dumps(default_plan().to_json()))
    return path


@pytest.fixture
def env(tmp_path: Path) -> dict[str, str]:
    out = dict(os.environ)
    out["TANDEM_DATA_DIR"] = str(tmp_path / "data")
    return out


def session_id(stdout: str) -> int:
    first = stdout.splitlines()[0]
    assert first.startswith("session "), stdout
    return int(first.split()[1])


def sessions_json(env: dict[str, str], *args: str) -> list[dict[str, Any]]:
    done = tandem("sessions", "list", "--json", *args, env=env)
    assert done.returncode == 0, done.stderr
    rows: list[dict[str, Any]] = json.loads(done.stdout)
    return rows


def one_error_line(done: subprocess.CompletedProcess[str]) -> str:
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    return lines[0]


def test_random_executions_of_a_paper_plan(tmp_path: Path, env: dict[str, str]) -> None:
    doc = paper_plan("paper-03")
    plan_path = tmp_path / "paper-03.json"
    plan_path.write_text(json.dumps(doc.to_json()))
    ids = []
    for seed in range(3):
        done = tandem(
            "execute", str(plan_path), "--responses", "random", "--seed", str(seed), env=env
        )
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip().splitlines()[-1].split()[2] == "goal"
        ids.append(session_id(done.stdout))
    with SessionStore(env["TANDEM_DATA_DIR"]) as store:
        for sid in ids:
            assert store.get(sid).result == "goal"
            assert store.get(sid).note == f"seed {ids.index(sid)}"
            assert is_plan_path(doc, store.path(sid))


def test_a_scenario_is_planned_then_executed(env: dict[str, str]) -> None:
    scenario = str(ROOT / "static" / "scenarios" / "default.toml")
    done = tandem("execute", scenario, "--responses", "random", "--seed", "9", env=env)
    assert done.returncode == 0, done.stderr
    rows = sessions_json(env)
    assert [(r["scenario"], r["result"], r["note"]) for r in rows] == [
        ("paper-base", "goal", "seed 9")
    ]


def test_click_reads_numbered_choices(plan_file: Path, env: dict[str, str]) -> None:
    done = tandem("execute", str(plan_file), env=env, stdin="1\n" * 200)
    assert done.returncode == 0, done.stderr
    assert "1) " in done.stderr
    sid = session_id(done.stdout)
    exported = json.loads(tandem("sessions", "export", str(sid), env=env).stdout)
    asked = [e for e in exported["events"] if e["outcome"] is not None]
    assert asked and {e["source"] for e in asked} == {"console"}
    for event in asked:  # choice 1 is the node's first child
        children = exported["plan"]["nodes"][event["node"]]["children"]
        assert event["outcome"] == children[0]["outcome"]


def test_click_without_input_takes_the_expected_outcomes(
    plan_file: Path, env: dict[str, str]
) -> None:
    done = tandem("execute", str(plan_file), "--responses", "click", env=env, stdin="")
    assert done.returncode == 0, done.stderr
    sid = session_id(done.stdout)
    with SessionStore(env["TANDEM_DATA_DIR"]) as store:
        # The plan's steps (a timed run also records the human's own actions).
        steps = [(str(e.action), e.outcome) for e in store.events(sid)
                 if e.kind != "goal" and is_step(e)]  # fmt: skip
    assert steps == Plan.read(plan_file).first_branch()


def test_sigkill_keeps_every_event_and_the_session_reads_interrupted(
    plan_file: Path, env: dict[str, str], tmp_path: Path
) -> None:
    doc = json.loads(plan_file.read_text())
    labels = [o for _, o in Plan.from_json(doc).first_branch() if o is not None]
    script = tmp_path / "answers.txt"
    script.write_text("# the hoped-for branch\n" + "\n".join(labels) + "\n")
    command = [
        *tandem_command(),
        "execute",
        str(plan_file),
        "--responses",
        f"scripted:{script}",
        "--step-delay",
        "0.3",
    ]
    child = subprocess.Popen(
        command, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    db = Path(env["TANDEM_DATA_DIR"]) / DB_NAME
    polled: list[tuple[Any, ...]] = []
    deadline = time.monotonic() + 120
    try:
        while len(polled) < 3:
            assert child.poll() is None, "the execution ended before it was killed"
            assert time.monotonic() < deadline, "no events appeared"
            if db.exists():
                try:
                    with sqlite3.connect(db) as conn:
                        polled = conn.execute("select * from events order by seq").fetchall()
                except sqlite3.OperationalError:
                    polled = []  # the tables are not created yet
            time.sleep(0.02)
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
    assert child.returncode == -signal.SIGKILL
    with sqlite3.connect(db) as conn:
        after = conn.execute("select * from events order by seq").fetchall()
    assert after[: len(polled)] == polled
    rows = sessions_json(env)
    assert len(rows) == 1 and rows[0]["result"] == "interrupted"
    assert rows[0]["events"] == len(after) >= 3
    sid = rows[0]["id"]
    export = tmp_path / "export.json"
    done = tandem("sessions", "export", str(sid), "-o", str(export), env=env)
    assert done.returncode == 0, done.stderr
    exported = json.loads(export.read_text())
    path = [(e["node"], e["outcome"]) for e in exported["events"]
            if is_step(exported_event(e))]  # fmt: skip
    assert is_plan_path(Plan.from_json(exported["plan"]), path, complete=False)
    assert not is_plan_path(Plan.from_json(exported["plan"]), path)
    shown = tandem("sessions", "show", str(sid), env=env)
    assert shown.returncode == 0 and "interrupted" in shown.stdout.splitlines()[0]


def test_a_wrong_scripted_label_names_its_line(
    plan_file: Path, env: dict[str, str], tmp_path: Path
) -> None:
    script = tmp_path / "answers.txt"
    script.write_text("# answers\nyes\nmaybe\n")
    done = tandem("execute", str(plan_file), "--responses", f"scripted:{script}", env=env)
    line = one_error_line(done)
    assert f"{script}:3: 'maybe' is not an outcome" in line
    assert not (Path(env["TANDEM_DATA_DIR"]) / DB_NAME).exists()


def test_a_label_wrong_at_its_node_falls_back(
    plan_file: Path, env: dict[str, str], tmp_path: Path
) -> None:
    script = tmp_path / "answers.txt"
    script.write_text("c2\n")  # an outcome of the plan, but not of the first question
    done = tandem("execute", str(plan_file), "--responses", f"scripted:{script}", env=env)
    assert done.returncode == 0, done.stderr
    assert f"{script}:1: 'c2' is not an outcome of" in done.stderr
    assert "taking the expected outcome" in done.stderr


def test_bad_input_is_one_line_and_exit_2(
    plan_file: Path, env: dict[str, str], tmp_path: Path
) -> None:
    cases = [
        ("execute", str(plan_file), "--responses", "psychic"),
        ("execute", str(plan_file), "--responses", "scripted:"),
        ("execute", str(plan_file), "--responses", f"scripted:{tmp_path / 'none.txt'}"),
        ("execute", str(tmp_path / "missing.json")),
        ("execute", str(plan_file), "--seed", "3"),
        ("execute", str(plan_file), "--step-delay", "-1"),
        ("execute", str(ROOT / "pyproject.toml")),
        ("sessions", "list", "--since", "yesterday"),
        ("sessions", "list", "--result", "won"),
        ("sessions", "show", "77"),
        ("sessions", "show", "abc"),
        ("sessions", "export", "77"),
        ("sessions", "export", "1", "-o", str(tmp_path / "no-such-dir" / "out.json")),
    ]
    # Session 1 exists, so exporting it fails only on the output path.
    done = tandem("execute", str(plan_file), "--responses", "random", "--seed", "0", env=env)
    assert session_id(done.stdout) == 1
    not_a_plan = tmp_path / "not-a-plan.json"
    not_a_plan.write_text("[1, 2]")
    cases.append(("execute", str(not_a_plan)))
    for args in cases:
        one_error_line(tandem(*args, env=env))


def test_data_dir_flag_wins_over_the_environment(
    plan_file: Path, env: dict[str, str], tmp_path: Path
) -> None:
    flagged = tmp_path / "flagged"
    args = ("execute", str(plan_file), "--responses", "random", "--seed", "1")
    assert tandem(*args, "--data-dir", str(flagged), env=env).returncode == 0
    assert (flagged / DB_NAME).exists()
    assert not (Path(env["TANDEM_DATA_DIR"]) / DB_NAME).exists()
    assert tandem(*args, env=env).returncode == 0
    assert len(sessions_json(env)) == 1
    listed = tandem("sessions", "list", "--json", "--data-dir", str(flagged), env=env)
    assert len(json.loads(listed.stdout)) == 1


def test_list_filters_through_the_command_line(plan_file: Path, env: dict[str, str]) -> None:
    for seed in range(2):
        args = ("execute", str(plan_file), "--responses", "random", "--seed", str(seed))
        assert tandem(*args, "--note", f"run {seed}", env=env).returncode == 0
    rows = sessions_json(env)
    assert [r["note"] for r in rows] == ["seed 0; run 0", "seed 1; run 1"]
    assert len(sessions_json(env, "--scenario", "paper-base")) == 2
    assert sessions_json(env, "--scenario", "paper-99") == []
    assert len(sessions_json(env, "--result", "goal")) == 2
    assert sessions_json(env, "--result", "aborted") == []
    assert len(sessions_json(env, "--since", "2000-01-01")) == 2
    assert sessions_json(env, "--since", "2999-01-01") == []
    table = tandem("sessions", "list", env=env)
    assert table.returncode == 0 and len(table.stdout.strip().splitlines()) == 3


def test_export_round_trip(plan_file: Path, env: dict[str, str], tmp_path: Path) -> None:
    done = tandem(
        "execute", str(plan_file), "--responses", "random", "--seed", "4", "--note", "x", env=env
    )
    sid = session_id(done.stdout)
    out = tmp_path / "session.json"
    assert tandem("sessions", "export", str(sid), "-o", str(out), env=env).returncode == 0
    to_stdout = tandem("sessions", "export", str(sid), env=env)
    exported = json.loads(out.read_text())
    assert json.loads(to_stdout.stdout) == exported
    with SessionStore(env["TANDEM_DATA_DIR"]) as store:
        assert exported == json.loads(json.dumps(store.export(sid)))
    assert exported["plan"] == json.loads(plan_file.read_text())
    path = [(e["node"], e["outcome"]) for e in exported["events"]
            if is_step(exported_event(e))]  # fmt: skip
    assert is_plan_path(Plan.from_json(exported["plan"]), path)


def test_a_headless_run_is_on_the_simulated_clock_with_true_lengths(
    plan_file: Path, env: dict[str, str]
) -> None:
    """Random and piped answers are no person: the session is simulated, its motions
    last their time-parameterised duration, the simulated human acts, and the session
    ends with its last event."""
    from app.execution.timing import motion_seconds

    plan = default_plan()
    for args, stdin in ((("--responses", "random", "--seed", "3"), None), ((), "1\n" * 200)):
        done = tandem("execute", str(plan_file), *args, env=env, stdin=stdin)
        assert done.returncode == 0, done.stderr
        sid = session_id(done.stdout)
        with SessionStore(env["TANDEM_DATA_DIR"], read_only=True) as store:
            record, events = store.get(sid), store.events(sid)
        assert record.clock == "simulated"
        motions = [e for e in events if e.kind == "actuation"]
        assert motions
        for event in motions:
            length = event.end - event.start  # type: ignore[operator]
            assert length >= 0.3
            assert length == pytest.approx(motion_seconds(plan.nodes[event.node].motion))
        assert any(e.kind == "human" and e.source == "simulated" for e in events)
        assert record.ended == max(e.end for e in events)  # type: ignore[type-var]
        shown = tandem("sessions", "show", str(sid), env=env).stdout
        assert "  clock     simulated (" in shown
        assert any(" human " in line and "(simulated)" in line for line in shown.splitlines())
