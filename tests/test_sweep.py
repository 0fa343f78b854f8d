"""`tandem sweep`: every variant planned and audited, one CSV row each, and a figure."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from PIL import Image, ImageStat

from planner.plan.model import STAT_KEYS
from planner.resources import find_scenario
from planner.scenario.loading import parse_scenario
from planner.sweep import Value, Variant, parse_variation, plan_variant, variants
from tests.plan_fixtures import tandem

SCENARIOS = ["declared.toml", "paper/paper-01.toml", "paper/paper-11.toml"]


def test_three_scenarios_by_four_variants_write_the_table_and_the_plot(tmp_path: Path) -> None:
    out = tmp_path / "results.csv"
    result = tandem(
        "sweep", *SCENARIOS, "--vary", "safety=strict,normal", "--vary", "verbosity=terse,chatty",
        "-o", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    with out.open() as f:
        reader = csv.DictReader(f)
        rows = list(reader)
        columns = reader.fieldnames
    assert columns is not None
    assert columns[:3] == ["scenario", "safety", "verbosity"]
    assert {*STAT_KEYS, "plan_s", "first_branch_s", "checks_s", "violations"} <= set(columns)
    assert len(rows) == 12
    combos = [(r["scenario"], r["safety"], r["verbosity"]) for r in rows]
    assert len(set(combos)) == 12
    assert {r["safety"] for r in rows} == {"strict", "normal"}
    assert all(r["violations"] == "0" and not r["error"] for r in rows)
    assert all(int(r["N"]) >= int(r["dag_nodes"]) > 0 and float(r["plan_s"]) > 0 for r in rows)
    # Verbosity changes what is said, so some scenario's tree changes with it.
    by = {(r["scenario"], r["safety"], r["verbosity"]): r["N"] for r in rows}
    assert any(by[(s, "normal", "terse")] != by[(s, "normal", "chatty")] for s, *_ in combos)
    png = out.with_suffix(".png")
    with Image.open(png) as image:
        assert image.format == "PNG" and image.width > 400 and image.height > 300
        stat = ImageStat.Stat(image.convert("L"))
        assert stat.stddev[0] > 5  # lines, ticks and labels, not one flat colour
        colours = image.convert("RGB").getcolors(maxcolors=1 << 16)  # None: even more
        assert colours is None or len(colours) > 20
    assert "wrote" in result.stdout and "paper-11" in result.stdout


def test_a_variant_is_the_scenario_with_the_setting_replaced() -> None:
    """Each variant's scenario carries its values, and so does the plan made of it."""
    path = find_scenario("declared.toml")
    vary = ["human.initiative=0,1", "verbosity=terse,chatty", "safety=strict,normal"]
    found = variants("declared", path.read_text(), [parse_variation(v) for v in vary])
    assert [v.settings for v in found] == [
        (("initiative", i), ("verbosity", v), ("safety", s))
        for i in (0, 1)
        for v in ("terse", "chatty")
        for s in ("strict", "normal")
    ]
    by_settings: dict[tuple[Value, ...], Variant] = {}
    for variant in found:
        settings = dict(variant.settings)
        scenario = parse_scenario(variant.text, "a variant")
        assert scenario.human.initiative == settings["initiative"]
        assert scenario.preferences.verbosity == settings["verbosity"]
        assert scenario.preferences.safety == settings["safety"]
        by_settings[tuple(settings.values())] = variant
    # The row is the variant's plan: a terse robot never greets, a chatty one does,
    # and a human who never takes the initiative needs no look at their hands.
    terse = plan_variant(by_settings[(0, "terse", "strict")])
    chatty = plan_variant(by_settings[(0, "chatty", "strict")])
    active = plan_variant(by_settings[(1, "terse", "strict")])
    relaxed = plan_variant(by_settings[(1, "terse", "normal")])
    assert terse["initiative"] == 0 and terse["violations"] == 0 and terse["N"] > 0
    assert terse["GE"] == 0 and chatty["GE"] > 0
    assert terse["S"] < active["S"]
    # Strict safety asks nothing of the human near a loose dangerous part.
    assert active["dag_nodes"] != relaxed["dag_nodes"]


def test_bad_variations_are_refused_before_planning(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="KEY=VALUE1,VALUE2"):
        parse_variation("safety")
    result = tandem("sweep", "declared.toml", "--vary", "safety=reckless", "-o",
                    str(tmp_path / "r.csv"))  # fmt: skip
    assert result.returncode == 2
    assert "safety" in result.stderr and not (tmp_path / "r.csv").exists()
