"""Ray as the engine: actors plan the same DAG as local workers; sweeps run as Ray tasks."""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from planner.audit.branches import audit
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from planner.sweep import parse_variation, variants
from tests.plan_fixtures import PAPER_NAMES, ROOT

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'tandem[cluster]'")


@pytest.fixture(scope="module", autouse=True)
def local_cluster() -> Iterator[None]:
    # One small local cluster for the whole module: starting Ray takes seconds.
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    except Exception as err:  # Ray's start-up raises many kinds (ports, /dev/shm, GCS)
        pytest.skip(f"a local Ray cluster cannot start here: {type(err).__name__}: {err}")
    yield
    ray.shutdown()


def _doc(**options: Any) -> dict[str, Any]:
    doc = plan_scenario(load_scenario(find_scenario(options.pop("name"))), **options)
    out = doc.plan.to_json()
    out["stats"] = {k: v for k, v in out["stats"].items() if not k.endswith("_s")}
    return out


@pytest.mark.parametrize("name", ["declared.toml", "paper/paper-03.toml"])
def test_one_and_two_ray_actors_give_the_plan_of_local_planning(name: str, tmp_path: Path) -> None:
    without = _doc(name=name, workers=2, window=2, cache_dir=tmp_path)
    one = _doc(name=name, workers=1, cluster="auto", window=2, cache_dir=tmp_path)
    two = _doc(name=name, workers=2, cluster="auto", window=2, cache_dir=tmp_path)
    assert len(without["nodes"]) > 20
    assert one == without
    assert two == without


def test_the_papers_instances_plan_on_ray_as_they_plan_here(tmp_path: Path) -> None:
    # Every instance of the paper: one actor gives the plan of local worker
    # processes (both solve history-free), two actors an audited-valid one.
    for name in PAPER_NAMES:
        path = f"paper/{name}.toml"
        local = _doc(name=path, workers=2, cache_dir=tmp_path)
        one = _doc(name=path, workers=1, cluster="auto", cache_dir=tmp_path)
        two = _doc(name=path, workers=2, cluster="auto", cache_dir=tmp_path)
        assert one == local, name
        assert audit(two) == [], name
        assert two == local, name


def test_local_workers_give_the_same_plan_for_one_window(monkeypatch: pytest.MonkeyPatch) -> None:
    # Results are integrated per round in request order and every solve depends on
    # its state alone, so the number of processes does not change the plan.
    from planner.search import hcp

    # On to the pool after 0.3 s, however few states are open then.
    monkeypatch.setattr(hcp, "SWITCH_MIN_OPEN", 0)
    pool = _doc(name="paper/paper-05.toml", workers=2, window=4, inline_s=0)
    assert pool == _doc(name="paper/paper-05.toml", workers=3, window=4, inline_s=0)
    # Nor does solving in this process first and in the pool later, or only here.
    assert pool == _doc(name="paper/paper-05.toml", workers=2, window=4, inline_s=0.3)
    assert pool == _doc(name="paper/paper-05.toml", workers=2, window=4, inline_s=math.inf)


def test_one_worker_keeps_the_solvers_defaults() -> None:
    from planner.search.branch_planner import Problem
    from planner.search.hcp import ConditionalPlanner, PlannerSettings

    problem = Problem(("part(top)",), frozenset(), 4)
    assert not ConditionalPlanner(problem, [], PlannerSettings(workers=1)).problem.history_free
    assert ConditionalPlanner(problem, [], PlannerSettings(workers=2)).problem.history_free


def test_a_sweep_runs_as_ray_tasks() -> None:
    from app.cli.sweep import run_variants

    path = find_scenario("declared.toml")
    todo = variants("declared", path.read_text(), [parse_variation("verbosity=terse,chatty")])
    rows = run_variants(todo, "auto", 0)
    assert [r["verbosity"] for r in rows] == ["terse", "chatty"]
    assert all(r["violations"] == 0 and r["N"] > 0 for r in rows)
    assert rows[0]["N"] != rows[1]["N"]


def test_without_cluster_ray_is_never_imported() -> None:
    code = (
        "import sys; from app.cli.main import main; "
        "rc = main(['plan', 'declared.toml', '--quiet']); "
        "print('RAY' if 'ray' in sys.modules else 'NO RAY', rc)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("NO RAY 0")
