"""Opening the session database, and saying in one line why it cannot be used.

A data folder that cannot be created, a file that is not a database or is
damaged, and a database this process may read but not write are the faults a
dashboard left running meets; each is a `StoreError` naming the file and the
fix. A database that can be read but not written is opened for reading, so
past sessions can still be reviewed.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from pathlib import Path

from sqlite_utils import Database

# The listing's filters (`SessionStore.list_sessions`) each walk an index in start
# order, so a study's 10,000 sessions filter in milliseconds. Created whenever a
# store is opened for writing, so a store older than them gets them too.
INDEXES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("sessions", ("scenario", "started")),
    ("sessions", ("result", "started")),
)


class StoreError(Exception):
    """The session database cannot be used (or written); `str()` is one line naming
    the file and what to do."""


def unusable(path: Path, err: sqlite3.Error) -> StoreError:
    return StoreError(
        f"{path}: not a usable session database ({err}); move it away or choose another --data-dir"
    )


def connect(db_path: Path, query: str = "") -> sqlite3.Connection:
    return sqlite3.connect(
        f"{db_path.absolute().as_uri()}{query}", uri=True, check_same_thread=False, timeout=30
    )


def create_indexes(db: Database) -> None:
    for table, columns in INDEXES:
        db.execute(
            f"create index if not exists idx_{table}_{'_'.join(columns)} "
            f"on {table} ({', '.join(columns)})"
        )


def open_database(
    db_path: Path, prepare: Callable[[Database], None], *, read_only: bool = False
) -> tuple[Database, str | None]:
    """The database at `db_path` (created with its folder if missing) and, when it
    can only be read, why; `prepare` creates the tables in a writable one."""
    reason = "opened for reading only" if read_only else None
    if not read_only:
        db: Database | None = None
        try:
            db_path.parent.mkdir(parents=True, exist_ok=True)
            db = Database(connect(db_path))
            db.execute("PRAGMA journal_mode=WAL")
            # In WAL mode NORMAL still keeps every commit across a killed process.
            db.execute("PRAGMA synchronous=NORMAL")
            prepare(db)
            create_indexes(db)
            # SQLite opens a file it may not write read-only without a word:
            # write once and roll back, so that shows now, not mid-session.
            db.execute("BEGIN IMMEDIATE")
            try:
                db.execute("insert into plans (hash, doc) values ('', '')")
            finally:
                db.execute("ROLLBACK")
            return db, None
        except OSError as err:
            if not db_path.is_file():
                raise StoreError(
                    f"{db_path.parent}: cannot create the data folder ({err.strerror}); "
                    "choose another with --data-dir or TANDEM_DATA_DIR"
                ) from None
            reason = f"{db_path.parent}: not writable ({err.strerror})"
        except sqlite3.DatabaseError as err:
            if db is not None:
                db.conn.close()
            if "readonly" not in str(err):
                raise unusable(db_path, err) from None
            reason = f"{db_path}: not writable ({err})"
    if not db_path.is_file():
        raise StoreError(f"{db_path}: no session database here; check --data-dir")
    failure: sqlite3.DatabaseError | None = None
    # mode=ro sees what a running writer has committed; a read-only folder
    # cannot hold WAL's shared-memory file, so then the file is read as it is.
    for query in ("?mode=ro", "?mode=ro&immutable=1"):
        try:
            db = Database(connect(db_path, query))
            db.execute("select count(*) from sessions").fetchone()
            return db, reason
        except sqlite3.DatabaseError as err:
            failure = err
    assert failure is not None
    raise unusable(db_path, failure) from None
