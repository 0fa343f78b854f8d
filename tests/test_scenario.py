"""Scenario files: the default instance's facts, and one-line errors from the real CLI."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from planner.scenario.loading import ScenarioError, load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = ROOT / "static" / "scenarios" / "declared.toml"

# A small valid scenario; each malformed case edits one spot of it.
BASE = """\
name = "base"

[[regions]]
id = "robotOnly"
x = [0.30, 0.65]
human_reach = false

[[regions]]
id = "shared"
human_reach = true

[[regions]]
id = "humanOnly"
human_reach = true

[feasibility.reachable]
left = ["robotOnly", "shared"]
right = ["robotOnly", "shared"]

[[parts]]
id = "top"
kind = "top"
region = "shared"
connections = ["c1", "c2"]
marker = 1

[[parts]]
id = "leg1"
kind = "leg"
length = "tall"
shape = "square"
region = "robotOnly"
marker = 2

[[parts]]
id = "leg2"
kind = "leg"
length = "tall"
shape = "square"
region = "humanOnly"

[[parts]]
id = "foot1"
kind = "foot"
shape = "square"
region = "shared"
dangerous = true

[[parts]]
id = "foot2"
kind = "foot"
shape = "square"
region = "shared"

[goal]
table = "stable"
"""

DEFAULT_FACTS = sorted(
    [
        "attachable(foot_square,leg_square)",
        "attachable(leg_square,top)",
        "class(foot_square,foot1)",
        "class(foot_square,foot2)",
        "class(leg_square,leg1)",
        "class(leg_square,leg2)",
        "class(top,top)",
        "connection(leg1,foot)",
        "connection(leg2,foot)",
        "connection(top,c1)",
        "connection(top,c2)",
        "dangerous(foot1)",
        "goal(foot1,leg1)",
        "goal(foot2,leg2)",
        "goal(leg1,top)",
        "goal(leg2,top)",
        "humanReach(humanOnly)",
        "humanReach(shared)",
        "initiative(1)",
        "loc(foot1,shared)",
        "loc(foot2,shared)",
        "loc(leg1,robotOnly)",
        "loc(leg2,humanOnly)",
        "loc(top,shared)",
        "manipulator(left)",
        "manipulator(right)",
        "movable(foot1)",
        "movable(foot2)",
        "movable(leg1)",
        "movable(leg2)",
        "part(foot1)",
        "part(foot2)",
        "part(leg1)",
        "part(leg2)",
        "part(top)",
        "reachable(left,foot1)",
        "reachable(left,foot2)",
        "reachable(left,leg1)",
        "reachable(left,top)",
        "reachable(right,foot1)",
        "reachable(right,foot2)",
        "reachable(right,leg1)",
        "reachable(right,top)",
        "region(humanOnly)",
        "region(robotOnly)",
        "region(shared)",
        "safety(normal)",
        "verbosity(normal)",
    ]
)


def edit(old: str, new: str, text: str = BASE) -> str:
    """`text` with its only `old` replaced, so a stale case cannot pass by editing nothing."""
    assert text.count(old) == 1, f"{old!r} must occur once in the base scenario"
    return text.replace(old, new)


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )


# --- the default scenario ----------------------------------------------------


def test_default_scenario_facts() -> None:
    scenario = load_scenario(DEFAULT)
    assert scenario.facts() == DEFAULT_FACTS


def test_default_scenario_goal_pairs() -> None:
    scenario = load_scenario(DEFAULT)
    assert scenario.goal_pairs() == [
        ("leg1", "top"),
        ("leg2", "top"),
        ("foot1", "leg1"),
        ("foot2", "leg2"),
    ]
    assert [p.id for p in scenario.parts] == ["top", "leg1", "leg2", "foot1", "foot2"]
    assert [r.id for r in scenario.regions] == ["robotOnly", "shared", "humanOnly"]
    assert scenario.sha256 == hashlib.sha256(DEFAULT.read_bytes()).hexdigest()


def test_base_matches_default_facts() -> None:
    assert parse_scenario(BASE, "base.toml").facts() == DEFAULT_FACTS


def test_cli_check_ok(tmp_path: Path) -> None:
    result = run_cli("scenario", "check", str(DEFAULT), cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout == f"{DEFAULT}: ok (5 parts, 4 goal attachments)\n"
    assert result.stderr == ""


# --- semantics beyond the default --------------------------------------------


def add_part_before_foot2(block: str, text: str = BASE) -> str:
    return edit('[[parts]]\nid = "foot2"', f'{block}\n[[parts]]\nid = "foot2"', text)


LEG3 = (
    '[[parts]]\nid = "leg3"\nkind = "leg"\nlength = "tall"\nshape = "square"\nregion = "shared"\n'
)
CLIP = (
    '[[parts]]\nid = "clip"\nkind = "other"\nclass = "clip"\nattaches_to = ["leg_square"]\n'
    'region = "shared"\n'
)
FOOT2 = '[[parts]]\nid = "foot2"\nkind = "foot"\nshape = "square"\nregion = "shared"\n'


def test_stable_table_takes_most_common_length() -> None:
    text = edit(
        'length = "tall"\nshape = "square"\nregion = "robotOnly"',
        'length = "short"\nshape = "square"\nregion = "robotOnly"',
    )
    pairs = parse_scenario(add_part_before_foot2(LEG3, text), "t.toml").goal_pairs()
    assert pairs == [("leg2", "top"), ("leg3", "top"), ("foot1", "leg2"), ("foot2", "leg3")]


def test_stable_table_tie_goes_to_first_leg_length() -> None:
    text = edit(
        'length = "tall"\nshape = "square"\nregion = "humanOnly"',
        'length = "short"\nshape = "square"\nregion = "humanOnly"',
    )
    text = edit(FOOT2, "", text)
    assert parse_scenario(text, "t.toml").goal_pairs() == [("leg1", "top"), ("foot1", "leg1")]


def test_attachments_goal_with_other_parts() -> None:
    goal = '[goal]\nattachments = [["leg1", "top"], ["foot1", "leg1"], ["clip", "leg2"]]'
    text = add_part_before_foot2(CLIP, edit('[goal]\ntable = "stable"', goal))
    scenario = parse_scenario(text, "t.toml")
    assert scenario.goal_pairs() == [("leg1", "top"), ("foot1", "leg1"), ("clip", "leg2")]
    facts = scenario.facts()
    assert "attachable(clip,leg_square)" in facts
    assert "class(clip,clip)" in facts and "movable(clip)" in facts
    assert "goal(clip,leg2)" in facts


def test_unreachable_parts_and_preferences() -> None:
    text = edit(
        '[[parts]]\nid = "top"',
        '[feasibility.unreachable_parts]\nright = ["foot1"]\n\n'
        '[preferences]\nsafety = "strict"\nverbosity = "chatty"\n\n[[parts]]\nid = "top"',
    )
    facts = parse_scenario(text, "t.toml").facts()
    assert "reachable(left,foot1)" in facts and "reachable(right,foot1)" not in facts
    assert "safety(strict)" in facts and "verbosity(chatty)" in facts


def test_reachable_override_for_geometry() -> None:
    text = edit(
        "[feasibility.reachable]", '[feasibility]\nsource = "geometry"\n\n[feasibility.reachable]'
    )
    scenario = parse_scenario(text, "t.toml")
    facts = scenario.facts(reachable={("left", "leg2")})
    assert [f for f in facts if f.startswith("reachable(")] == ["reachable(left,leg2)"]
    with pytest.raises(ValueError, match="unknown"):
        scenario.facts(reachable={("middle", "leg2")})


def test_scenario_error_is_one_line() -> None:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(edit('region = "robotOnly"', 'region = "kitchen"'), "bad.toml")
    assert str(info.value) == (
        "bad.toml: parts[1].region: unknown region 'kitchen' (known: robotOnly, shared, humanOnly)"
    )
    assert (info.value.source, info.value.field) == ("bad.toml", "parts[1].region")


def test_cli_without_action_exits_2(tmp_path: Path) -> None:
    result = run_cli("scenario", cwd=tmp_path)
    assert result.returncode == 2
    assert "check" in result.stderr and "Traceback" not in result.stderr


# --- malformed scenarios through the real CLI --------------------------------

TOP_EXTRA = '[[parts]]\nid = "top"'
NO_REGIONS = 'name = "base"\nregions = []\n\n' + BASE[BASE.index("[feasibility.reachable]") :]
OTHER_CLIP = (
    '[[parts]]\nid = "clip"\nkind = "other"\nclass = "clip"\nattaches_to = ["bolt"]\n'
    'region = "shared"\n\n[[parts]]\nid = "top"'
)

# (case id, scenario text or None for "no file", field path, words in the message)
MALFORMED: list[tuple[str, str | None, str, str]] = [
    ("unreadable", None, "file", "cannot read"),
    ("toml-syntax", edit('name = "base"', 'name = "base'), "line 1, column", "invalid TOML"),
    (
        "toml-duplicate-key",
        edit('name = "base"', 'name = "base"\nname = "again"'),
        "line 2, column",
        "invalid TOML",
    ),
    ("missing-name", edit('name = "base"\n', ""), "name", "missing"),
    (
        "missing-part-region",
        edit('region = "robotOnly"\nmarker = 2', "marker = 2"),
        "parts[1].region",
        "missing",
    ),
    (
        "wrong-type-bool",
        edit("dangerous = true", 'dangerous = "yes"'),
        "parts[3].dangerous",
        "expected true or false, got string 'yes'",
    ),
    (
        "wrong-type-table",
        edit(
            'name = "base"',
            'name = "base"\ngoal = "stable"',
            edit('[goal]\ntable = "stable"\n', ""),
        ),
        "goal",
        "expected a table",
    ),
    (
        "wrong-length",
        edit("x = [0.30, 0.65]", "x = [0.30]"),
        "regions[0].x",
        "expected at least 2 items, got 1",
    ),
    (
        "bad-literal",
        edit(TOP_EXTRA, f'[preferences]\nsafety = "high"\n\n{TOP_EXTRA}'),
        "preferences.safety",
        "expected 'relaxed', 'normal' or 'strict'",
    ),
    ("no-regions", NO_REGIONS, "regions", "expected at least 1 item, got 0"),
    ("duplicate-part", edit('id = "leg2"', 'id = "leg1"'), "parts[2].id", "duplicate part 'leg1'"),
    (
        "duplicate-region",
        edit('id = "humanOnly"', 'id = "shared"'),
        "regions[2].id",
        "duplicate region 'shared'",
    ),
    ("duplicate-marker", edit("marker = 2", "marker = 1"), "parts[1].marker", "duplicate marker 1"),
    (
        "unknown-region",
        edit('region = "robotOnly"', 'region = "kitchen"'),
        "parts[1].region",
        "unknown region 'kitchen' (known: robotOnly, shared, humanOnly)",
    ),
    (
        "unknown-goal-part",
        edit('table = "stable"', 'attachments = [["legX", "top"]]'),
        "goal.attachments[0][0]",
        "unknown part 'legX'",
    ),
    (
        "non-attachable-goal",
        edit('table = "stable"', 'attachments = [["foot1", "top"]]'),
        "goal.attachments[0]",
        "cannot be attached to 'top'",
    ),
    (
        "goal-moves-top",
        edit('table = "stable"', 'attachments = [["top", "leg1"]]'),
        "goal.attachments[0][0]",
        "table top",
    ),
    (
        "goal-overloads-top",
        edit(
            'table = "stable"',
            'attachments = [["leg1", "top"], ["leg2", "top"]]',
            edit('connections = ["c1", "c2"]', 'connections = ["c1"]'),
        ),
        "parts[0].connections",
        "2 parts",
    ),
    (
        "foot-without-leg",
        edit(
            'shape = "square"\nregion = "shared"\n\n[goal]',
            'shape = "round"\nregion = "shared"\n\n[goal]',
        ),
        "parts[4].shape",
        "foot 'foot2' has no matching leg",
    ),
    ("leg-without-foot", edit(FOOT2, ""), "parts[2].shape", "leg 'leg2' has no matching foot"),
    (
        "too-few-connections",
        edit('connections = ["c1", "c2"]', 'connections = ["c1"]'),
        "parts[0].connections",
        "at least 2 connection points",
    ),
    (
        "leg-without-length",
        edit(
            'length = "tall"\nshape = "square"\nregion = "robotOnly"',
            'shape = "square"\nregion = "robotOnly"',
        ),
        "parts[1].length",
        "a leg needs a length",
    ),
    (
        "shape-on-top",
        edit('kind = "top"', 'kind = "top"\nshape = "round"'),
        "parts[0].shape",
        "not allowed for kind 'top'",
    ),
    ("bad-id", edit('id = "leg1"', 'id = "Leg-1"'), "parts[1].id", "bad id 'Leg-1'"),
    (
        "bad-connection-id",
        edit('["c1", "c2"]', '["c1", "2"]'),
        "parts[0].connections[1]",
        "bad id '2'",
    ),
    (
        "unknown-manipulator",
        edit("right = [", "middle = ["),
        "feasibility.reachable.middle",
        "unknown manipulator 'middle' (known: left, right)",
    ),
    (
        "unknown-feasibility-region",
        edit('right = ["robotOnly", "shared"]', 'right = ["garage"]'),
        "feasibility.reachable.right[0]",
        "unknown region 'garage'",
    ),
    (
        "unknown-attaches-to-class",
        edit(TOP_EXTRA, OTHER_CLIP),
        "parts[0].attaches_to[0]",
        "unknown class 'bolt'",
    ),
    (
        "table-and-attachments",
        edit('table = "stable"', 'table = "stable"\nattachments = [["leg1", "top"]]'),
        "goal",
        "exactly one of `table` or `attachments`",
    ),
    ("neither-table-nor-attachments", edit('table = "stable"', ""), "goal", "exactly one of"),
    (
        "extra-field",
        edit('id = "leg1"', 'id = "leg1"\ncolour = "red"'),
        "parts[1].colour",
        "unknown field (allowed: id, kind, region,",
    ),
    (
        "extra-top-level-field",
        edit('name = "base"', 'name = "base"\nsha256 = "x"'),
        "sha256",
        "unknown field",
    ),
]


@pytest.mark.parametrize(
    ("text", "field", "words"),
    [pytest.param(text, field, words, id=case) for case, text, field, words in MALFORMED],
)
def test_malformed_scenario_cli(tmp_path: Path, text: str | None, field: str, words: str) -> None:
    if text is not None:
        (tmp_path / "bad.toml").write_text(text)
    result = run_cli("scenario", "check", "bad.toml", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stdout == ""
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"bad.toml: {field}"), lines[0]
    assert words in lines[0], lines[0]


def test_not_utf8(tmp_path: Path) -> None:
    (tmp_path / "bad.toml").write_bytes(b'name = "caf\xe9"\n')
    result = run_cli("scenario", "check", "bad.toml", cwd=tmp_path)
    assert (result.returncode, result.stderr) == (2, "bad.toml: file: not UTF-8 text (byte 11)\n")


def test_malformed_cases_are_distinct() -> None:
    texts = [text for _, text, _, _ in MALFORMED]
    assert len(set(texts)) == len(texts) >= 12
