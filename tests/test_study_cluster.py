"""`tandem study --cluster`: Ray tasks that cannot see the data folder send their
sessions back, and the study's process stores every one of them, whole."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.cli.main import main
from app.sessions.database import StoreError
from app.sessions.store import SessionStore
from app.sessions.studies import FINAL_RESULTS, finished, study_sessions
from tests.plan_fixtures import tandem

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'tandem[cluster]'")

# Surprising participants make the executor plan again (the repairs' plans travel
# too); the simulated camera keeps the pictures that decided its answers.
STUDY = """[study]
name = "far"
participants = 2
seed = 3

[conditions]
scenario = "default.toml"
behaviour = "surprising"
channel = ["clicks", "camera"]
"""


@pytest.fixture
def workers_without_the_data(tmp_path: Path) -> Iterator[Path]:
    """A local Ray cluster whose workers run in their own folder, where `data` is a
    file and the default store's folder too: no worker can open a store there."""
    own = tmp_path / "workers"
    own.mkdir()
    (own / "data").write_text("a file where the study's store would be\n")
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False,
                 runtime_env={"working_dir": str(own),
                              "env_vars": {"TANDEM_DATA_DIR": "data"}})  # fmt: skip
    except Exception as err:  # Ray's start-up raises many kinds (ports, /dev/shm, GCS)
        pytest.skip(f"a local Ray cluster cannot start here: {type(err).__name__}: {err}")
    yield own
    ray.shutdown()


def _relative_times(store: SessionStore, session_id: int) -> list[tuple[object, ...]]:
    started = store.get(session_id).started
    return [
        (e.seq, e.kind, e.node, e.outcome, e.source, e.text, e.evidence is not None,
         round((e.start or 0) - started, 6), round((e.end or 0) - started, 6))
        for e in store.events(session_id, with_jpeg=True)
    ]  # fmt: skip


def test_a_cluster_study_stores_every_session_in_the_studys_own_store(
    tmp_path: Path, workers_without_the_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The premise: a worker that opened the study's store (`data`, relative to the
    # study's folder) or its own default one would fail. (Defined here, the probe
    # travels to the workers by value: they cannot import the tests.)
    def _open_a_store(data_dir: str | None) -> str:
        try:
            SessionStore(data_dir).close()
        except StoreError as err:
            return f"refused: {err}"
        return "opened"

    refused = ray.get([ray.remote(_open_a_store).remote(d) for d in ("data", None)])
    assert all(r.startswith("refused:") for r in refused), refused

    here = tmp_path / "study"
    here.mkdir()
    (here / "far.toml").write_text(STUDY)
    monkeypatch.chdir(here)
    assert main(["study", "far.toml", "--cluster", "auto", "--data-dir", "data"]) == 0
    # Run here, without Ray (in a process of its own: no fork beside Ray's threads),
    # the same study gives the same sessions.
    local = [str(here / name) for name in ("far.toml", "local", "local-out")]
    run = tandem("study", local[0], "--workers", "1", "--data-dir", local[1], "--out", local[2])
    assert run.returncode == 0, run.stderr

    with SessionStore(here / "data", read_only=True) as far, \
            SessionStore(here / "local", read_only=True) as near:  # fmt: skip
        tagged = study_sessions(far.db, "far")
        assert len(tagged) == 4 and all(s.result in FINAL_RESULTS for s in tagged)
        assert all(s.clock == "simulated" for s in tagged)
        alike = finished(study_sessions(near.db, "far"))
        for session in tagged:
            events = far.events(session.session_id, with_jpeg=True)
            record = far.get(session.session_id)
            assert record.pid is not None and record.ended == max(e.end or 0 for e in events)
            same = alike[(session.condition, session.participant)]
            assert _relative_times(far, session.session_id) == _relative_times(
                near, same.session_id
            )
        # The repairs' plans arrived with their sessions: each repair's plan is stored.
        replanned = [e.evidence.replanned for s in tagged for e in far.events(s.session_id)
                     if e.evidence is not None and e.evidence.replanned is not None]  # fmt: skip
        assert replanned
        for repair in replanned:
            far.plan_doc(repair.plan)
        # And the camera's pictures.
        pictures = [e for s in tagged for e in far.events(s.session_id, with_jpeg=True)
                    if e.evidence is not None and e.evidence.jpeg]  # fmt: skip
        assert pictures
    with (here / "far" / "sessions.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert sorted(int(r["session_id"]) for r in rows) == sorted(s.session_id for s in tagged)
