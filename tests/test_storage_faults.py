"""Storage faults give one line naming the file and the fix: never a traceback.

File modes are what is tested, and root ignores them, so those commands run
without privileges: `setpriv` drops every capability (root without
CAP_DAC_OVERRIDE obeys file modes like anyone).
"""

from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.execution.walker import Executor
from app.sessions.database import StoreError
from app.sessions.store import DB_NAME, SessionStore
from app.sources.outcomes import ExpectedSource
from tests.plan_fixtures import ROOT, default_plan, free_port, tandem_command


def unprivileged(command: list[str]) -> list[str]:
    if os.geteuid() != 0:
        return command
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.fail("setpriv (util-linux) is needed to test file modes as root")
    return [setpriv, "--bounding-set=-all", "--inh-caps=-all", *command]


def run(*args: str, data: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "TANDEM_DATA_DIR": str(data)}
    return subprocess.run(
        unprivileged([*tandem_command(), *args]),
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def one_line(result: subprocess.CompletedProcess[str], *words: str) -> None:
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    for word in words:
        assert word in lines[0], lines[0]


@pytest.fixture
def folder() -> Iterator[Path]:
    # Not under pytest's tmp_path: its parents may be closed to other users.
    path = Path(tempfile.mkdtemp(prefix="tandem-faults-"))
    yield path
    for p in [path, *path.rglob("*")]:
        if p.is_dir() and not p.is_symlink():
            p.chmod(0o755)
    shutil.rmtree(path)


@pytest.fixture
def with_session(folder: Path) -> Path:
    """A data folder holding one finished session."""
    data = folder / "data"
    plan = default_plan()
    with SessionStore(data) as store:
        sid = store.start(plan)
        executor = Executor(plan, ExpectedSource(), [store.recorder(sid)])
        store.finish(sid, executor.run())
    return data


def test_a_data_folder_that_cannot_be_created(folder: Path) -> None:
    locked = folder / "locked"
    locked.mkdir(mode=0o555)
    for args in (("sessions", "list"), ("dashboard", "--port", "0")):
        one_line(run(*args, data=locked / "data"), str(locked / "data"), "--data-dir")


def test_a_corrupt_database(folder: Path) -> None:
    data = folder / "data"
    data.mkdir()
    (data / DB_NAME).write_bytes(b"this is not sqlite" * 100)
    for args in (("sessions", "list"), ("execute", "default.toml")):
        one_line(run(*args, data=data), str(data / DB_NAME), "move it away")


def make_read_only(data: Path) -> None:
    """The data folder and its database as a user may read but not write them: the
    write-ahead log folded in first, so the database is whole without it."""
    db = data / DB_NAME
    with sqlite3.connect(db) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    for p in (db, data):
        p.chmod(0o555 if p.is_dir() else 0o444)


def test_a_read_only_database_is_read_but_never_executed_into(with_session: Path) -> None:
    make_read_only(with_session)
    listed = run("sessions", "list", data=with_session)
    assert listed.returncode == 0, listed.stderr
    assert "goal" in listed.stdout
    shown = run("sessions", "show", "1", data=with_session)
    assert shown.returncode == 0 and "goal" in shown.stdout, shown.stderr
    # Refused before it runs: an execution is never left unrecorded.
    one_line(run("execute", "default.toml", data=with_session), "cannot record", "not writable")


def test_a_damaged_page_read_later_is_one_error(with_session: Path) -> None:
    store = SessionStore(with_session)
    store.close()
    db = with_session / DB_NAME
    with sqlite3.connect(db) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        page_size = conn.execute("PRAGMA page_size").fetchone()[0]
    raw = bytearray(db.read_bytes())
    assert len(raw) > 3 * page_size
    raw[page_size:] = b"\xff" * (len(raw) - page_size)  # the header survives, the pages do not
    db.write_bytes(bytes(raw))
    with pytest.raises(StoreError, match="not a usable session database") as err:
        store = SessionStore(with_session)
        store.events(1)
    assert "\n" not in str(err.value)


def test_a_write_failing_mid_session_stops_it_and_keeps_what_was_committed(
    with_session: Path,
) -> None:
    plan = default_plan()
    store = SessionStore(with_session)
    sid = store.start(plan)
    written: list[int] = []

    def then_fail(event: object) -> None:
        written.append(1)
        if len(written) == 3:
            store.db.conn.execute("PRAGMA query_only = ON")  # every later write fails

    executor = Executor(plan, ExpectedSource(), [store.recorder(sid), then_fail])
    with pytest.raises(StoreError, match="cannot write"):
        executor.run()
    assert executor.result == "aborted"
    store.db.conn.execute("PRAGMA query_only = OFF")
    assert [e.seq for e in store.events(sid)] == [0, 1, 2]
    store.close()


def test_the_dashboard_opens_a_read_only_database_for_review_only(with_session: Path) -> None:
    make_read_only(with_session)
    port = free_port()
    env = {**os.environ, "TANDEM_DATA_DIR": str(with_session)}
    process = subprocess.Popen(
        unprivileged([*tandem_command(), "dashboard", "--port", str(port)]),
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert process.stderr is not None
        line = process.stderr.readline()
        assert line.startswith("review only: ") and "not writable" in line, line
        assert process.poll() is None  # it serves the page for review
    finally:
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "Traceback" not in err
