"""Check results on disk (SQLite), so re-planning the same bench costs nothing.

A result is stored under the hash of everything that could change it: the bench
geometry (regions, part boxes, robot base), the motion planner's parameters and
`MODEL_VERSION`, bumped whenever the checking code changes its answers. The file
lives in `TANDEM_CACHE_DIR`, else `$XDG_CACHE_HOME/tandem`, else `~/.cache/tandem`.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

from planner.feasibility.scene import part_boxes, region_extents
from planner.scenario.model import Scenario

# Bump when reach.py, path_planner.py, robot.py or scene.py change what a check returns.
# 6: a reach path's simplification restarts OMPL's seed sequence (reach.py), so it
# can run after other checks; 4 of the ~700 paths of the paper's benches and the
# families to n=10 changed, no answer did.
# 7: IK by `kinematics.ArmChain` instead of pybullet's, and paths simplified by a
# fixed sequence of steps instead of `simplifyMax` (path_planner.py): every answer
# of the paper's benches, the families to n = 10 and the shipped scenarios is the
# same (612 pairs and points), but the grasp configurations and paths differ.
MODEL_VERSION = 7
FILE_NAME = "feasibility.sqlite"
# How long an opening or a write waits for another planner's lock on the file.
LOCK_WAIT_S = 30.0


def default_dir() -> Path:
    explicit = os.environ.get("TANDEM_CACHE_DIR")
    if explicit:
        return Path(explicit)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "tandem"


def geometry_key(scenario: Scenario, **parameters: Any) -> str:
    """The hash of the scenario's geometry and the check parameters."""
    doc = {
        "version": MODEL_VERSION,
        "regions": region_extents(scenario),
        "parts": {pid: asdict(box) for pid, box in sorted(part_boxes(scenario).items())},
        "base": scenario.robot.base_pose,
        "parameters": parameters,
    }
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _use_wal(db: sqlite3.Connection) -> None:
    """Several planners may share the file: WAL lets readers run beside a writer.

    The switch is kept in the file, so only the first opening of a new file makes
    it; SQLite answers "database is locked" at once, without its busy wait, to an
    opening that asks while another is switching (a sweep's processes start
    together), so the switch is asked again until it is made or `LOCK_WAIT_S` ends.
    """
    deadline = time.monotonic() + LOCK_WAIT_S
    while True:
        try:
            db.execute("PRAGMA journal_mode=WAL")
            return
        except sqlite3.OperationalError as err:
            if "locked" not in str(err) or time.monotonic() > deadline:
                raise
            time.sleep(0.005)


class CheckCache:
    """Key -> JSON value; `directory=None` uses `default_dir()`, ":memory:" keeps nothing."""

    def __init__(self, directory: Path | str | None = None) -> None:
        # Planning may ask from a thread other than the one that opened the cache
        # (`planner.search.hoped_planning`): one connection, one caller at a time.
        self._lock = threading.Lock()
        if directory == ":memory:":
            self._db = sqlite3.connect(":memory:", check_same_thread=False)
        else:
            folder = Path(directory) if directory is not None else default_dir()
            folder.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(
                folder / FILE_NAME, timeout=LOCK_WAIT_S, check_same_thread=False
            )
            _use_wal(self._db)
            # A commit need not wait for the disk (a cache: an answer lost with the
            # power is checked again; WAL keeps the file whole either way): the
            # planning process writes every answer as it comes (1.1 ms a commit).
            self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.execute("CREATE TABLE IF NOT EXISTS checks (key TEXT PRIMARY KEY, value TEXT)")
        self.hits = 0
        self.misses = 0

    def get(self, key: str) -> Any:
        with self._lock:
            row = self._db.execute("SELECT value FROM checks WHERE key = ?", (key,)).fetchone()
        if row is None:
            self.misses += 1
            return None
        self.hits += 1
        return json.loads(row[0])

    def put(self, key: str, value: Any) -> None:
        with self._lock, self._db:
            self._db.execute(
                "INSERT OR REPLACE INTO checks (key, value) VALUES (?, ?)",
                (key, json.dumps(value, separators=(",", ":"))),
            )

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def __enter__(self) -> CheckCache:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
