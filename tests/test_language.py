"""The `[human] language` field: the facts, the robot's sentences, one-line errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from planner.scenario.loading import ScenarioError, load_scenario
from planner.vocabulary import QUESTIONS
from tests.plan_fixtures import KOREAN_DEFAULT, SCENARIOS, default_plan, korean_plan


def test_default_language_is_english_and_adds_no_fact() -> None:
    scenario = load_scenario(SCENARIOS / "default.toml")
    assert scenario.human.language == "en-us"
    assert not [f for f in scenario.facts() if f.startswith("language(")]


def test_the_korean_copy_differs_from_the_default_only_in_language_and_name() -> None:
    english = load_scenario(SCENARIOS / "default.toml")
    korean = load_scenario(KOREAN_DEFAULT)
    assert korean.human.language == "ko"
    assert set(korean.facts()) - set(english.facts()) == {'language("ko")'}
    assert set(english.facts()) - set(korean.facts()) == set()


def test_korean_plan_speaks_korean_and_keeps_the_english_plan_shape() -> None:
    english, korean = default_plan(), korean_plan()
    assert english.stats is not None and korean.stats is not None
    for key in ("L", "N", "K", "O", "CF", "R"):
        assert english.stats[key] == korean.stats[key], key
    spoken = [n for n in korean.nodes.values() if n.kind == "communication"]
    assert {n.action.name for n in spoken if n.action} >= set(QUESTIONS)
    for node in spoken:
        assert node.say and any("\uac00" <= c <= "\ud7a3" for c in node.say), node.say
        assert node.action is not None
        # A greeting or a goodbye names no part; everything else names its first one.
        assert not node.action.arguments or node.action.arguments[0] in node.say
    assert all(
        n.say and n.say.isascii() for n in english.nodes.values() if n.kind == "communication"
    )


def test_an_unknown_language_is_one_line_naming_the_field(tmp_path: Path) -> None:
    text = (SCENARIOS / "default.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text + '\n[human]\nlanguage = "fr"\n', encoding="utf-8")
    with pytest.raises(ScenarioError) as error:
        load_scenario(bad)
    message = str(error.value)
    assert "\n" not in message and "human.language" in message and "'ko'" in message
