"""The paper's benchmark: generated scenario files, planning them, `tandem bench`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from app.benchmark import planner_benchmark
from planner.scenario import paper
from planner.scenario.loading import load_scenario
from tests.plan_fixtures import tandem

ROOT = Path(__file__).resolve().parent.parent
PAPER_DIR = ROOT / "static" / "scenarios" / "paper"
PAPER_NAMES = [f"paper-{i:02d}" for i in range(1, 16)]


def test_files_on_disk_are_what_the_generator_writes() -> None:
    expected = paper.generated_files()
    on_disk = {p.name for p in PAPER_DIR.glob("*.toml")}
    assert on_disk == set(expected), "run: tandem scenario paper static/scenarios/paper"
    for name, text in expected.items():
        assert (PAPER_DIR / name).read_text(encoding="utf-8") == text, name


def test_instance_names_follow_the_paper_numbering() -> None:
    names = [paper.instance_name(f, n) for f, n in paper.all_instances(families=False)]
    assert names == PAPER_NAMES
    assert paper.instance_name("U", 2) == "paper-01"
    assert paper.instance_name("P", 2) == "paper-06"
    assert paper.instance_name("R", 6) == "paper-15"
    assert paper.instance_name("R", 10) == "R10"
    # The 15 instances, the families continued to n=10, and the real-world task last.
    assert len(planner_benchmark.instances()) == 28
    assert len(planner_benchmark.instances(families=False)) == 16
    assert planner_benchmark.instances()[-1] == planner_benchmark.REAL_WORLD
    assert planner_benchmark.instances(["real-world"]) == [planner_benchmark.REAL_WORLD]


@pytest.mark.parametrize("name", PAPER_NAMES)
def test_every_paper_instance_loads_and_grows_its_quantity(name: str) -> None:
    number = int(name[-2:])
    family, n = paper.FAMILIES[(number - 1) // 5], (number - 1) % 5 + 2
    scenario = load_scenario(PAPER_DIR / f"{name}.toml")
    assert scenario.name == name
    assert f"paper instance {number} " in (scenario.description or "")
    parts = scenario.parts
    counts = {
        "U": sum(p.dangerous for p in parts),
        "P": sum(p.region == "humanOnly" for p in parts),
        "R": sum(p.region == "robotOnly" for p in parts),
    }
    # The grown quantity is n; the other two stay at the base instance's 1.
    assert counts == {f: n if f == family else 1 for f in paper.FAMILIES}
    extents = {r.id: r.x for r in scenario.regions}
    for p in parts:
        assert p.pose is not None
        lo, hi = extents[p.region] or (0.0, 0.0)
        assert lo <= p.pose[0] <= hi, p.id
        assert -0.5 <= p.pose[1] <= 0.5, p.id
    markers = [p.marker for p in parts]
    assert len(set(markers)) == len(markers)


def test_paper_transcription_agrees_with_its_prose() -> None:
    # The paper's discussion quotes these cells of its tables.
    table = planner_benchmark.PAPER
    assert (table[1].D, table[1].DN, table[1].L) == (25, 104, 17)
    assert (table[5].D, table[5].DN, table[5].L) == (42, 511, 29)
    assert [table[i].plan_s for i in (1, 5, 6, 10, 11, 15)] == [
        588, 5873, 657, 6389, 422, 1090
    ]  # fmt: skip
    assert (table[6].N, table[10].N, table[11].N) == (367, 1534, 249)


@pytest.mark.parametrize("name", ["paper-01", "paper-11"])
def test_plan_then_check_passes(name: str, tmp_path: Path) -> None:
    out = tmp_path / f"{name}.json"
    planned = tandem("plan", f"static/scenarios/paper/{name}.toml", "--workers", "1", "--quiet",
                     "-o", str(out))  # fmt: skip
    assert planned.returncode == 0, planned.stderr
    checked = tandem("check", str(out))
    assert checked.returncode == 0, checked.stdout + checked.stderr


def test_bench_json_smoke() -> None:
    result = tandem("bench", "--only", "paper-01", "--json", "--workers", "1")
    assert result.returncode in (0, 1), result.stderr  # 1: the audit found violations
    rows = json.loads(result.stdout)
    assert len(rows) == 1
    row = rows[0]
    assert set(row) == {
        "instance", "family", "n", "paper_instance", *planner_benchmark.STAT_KEYS,
        "first_branch_s", "plan_s", "runs_s", "checks_cold_s", "checks_cached_s", "solves",
        "check", "violations", "audit_s", "error", "paper", "ratio",
    }  # fmt: skip
    assert (row["instance"], row["family"], row["n"], row["paper_instance"]) == (
        "paper-01", "U", 2, 1
    )  # fmt: skip
    assert row["error"] is None and row["N"] >= row["dag_nodes"] > 0
    assert row["paper"] == {
        "L": 17, "D": 25, "A": 8, "S": 6, "C": 11, "K": 1, "O": 3, "CF": 6, "R": 1,
        "DN": 104, "BF": 4, "N": 346, "plan_s": 588, "checks_s": 31,
    }  # fmt: skip
    assert row["ratio"] == pytest.approx(588 / row["plan_s"], rel=0.05)


def test_bench_rejects_unknown_instance() -> None:
    result = tandem("bench", "--only", "paper-99")
    assert result.returncode == 2
    assert "unknown instance paper-99" in result.stderr


@pytest.mark.parametrize("name", PAPER_NAMES)
def test_every_paper_instance_plans_with_geometry_and_passes_the_audit(
    name: str, tmp_path: Path
) -> None:
    from planner.audit.branches import audit
    from planner.feasibility import BenchChecks, CheckCache
    from planner.planning import plan_scenario

    scenario = load_scenario(PAPER_DIR / f"{name}.toml")
    assert scenario.feasibility.source == "geometry"
    cold = plan_scenario(scenario, workers=1, cache_dir=tmp_path).plan
    assert audit(cold.to_json()) == []
    stats = cold.statistics
    assert stats["L"] >= 2 and stats["K"] >= 1  # contingencies, and help asked
    actuation = [n for n in cold.nodes.values() if n.kind == "actuation"]
    assert actuation and all(n.motion and len(n.motion.path[0]) == 7 for n in actuation)
    # The motion planner, not a table, makes the paper's regions what they are:
    # some arm reaches every robot-only and shared part, none a human-only one.
    with CheckCache(tmp_path) as cache, BenchChecks(scenario, cache=cache) as checks:
        table = checks.table()
        assert cache.misses == 0  # all answered by the cache the plan filled
    for part in scenario.parts:
        reached = any(table[(arm, part.id)].reachable for arm in ("left", "right"))
        assert reached == (part.region != "humanOnly"), part.id
    # Planning again from the filled cache gives the same plan.
    warm = plan_scenario(scenario, workers=1, cache_dir=tmp_path).plan
    assert _without_timings(warm.to_json()) == _without_timings(cold.to_json())


def _without_timings(doc: dict[str, Any]) -> dict[str, Any]:
    stats = {k: v for k, v in doc["stats"].items() if not k.endswith("_s")}
    return {**doc, "stats": stats}
