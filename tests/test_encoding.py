"""Loading the encodings: each file under its own name, clingo's messages forwarded."""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import pytest

from planner.resources import encoding_dir
from planner.search import encoding
from tests.domain_fixtures import scenario


def _facts() -> tuple[list[str], encoding.FeasibilityContext]:
    sc = scenario()
    reach = sc.reachable_pairs()
    facts = [f for f in sc.facts(reach) if not f.startswith("reachable(")]
    return facts, encoding.FeasibilityContext(lambda m, p: (m, p) in reach)


def _copy_of_the_encodings(to: Path) -> Path:
    for name in encoding.CONCERNS:
        shutil.copy2(Path(str(encoding_dir() / f"{name}.lp")), to / f"{name}.lp")
    return to


def _append_to_line(file: Path, number: int, text: str) -> None:
    lines = file.read_text().splitlines()
    lines[number - 1] += text
    file.write_text("\n".join(lines) + "\n")


def test_a_syntax_error_names_the_file_and_line(tmp_path: Path) -> None:
    broken = _copy_of_the_encodings(tmp_path)
    _append_to_line(broken / "sensing.lp", 12, " :- :-")
    facts, context = _facts()
    with pytest.raises(encoding.EncodingError) as raised:
        encoding.ground(facts, 4, context, directory=broken)
    message = str(raised.value)
    assert f"{broken / 'sensing.lp'}:12:" in message
    assert "syntax error" in message


def test_an_undefined_atom_is_logged_with_its_file_and_line(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    edited = _copy_of_the_encodings(tmp_path)
    _append_to_line(edited / "goal.lp", 3, "\nneverDerived(T) :- time(T), undefinedAtom(T).")
    facts, context = _facts()
    with caplog.at_level(logging.WARNING, logger="planner.search.encoding"):
        encoding.ground(facts, 4, context, directory=edited)
    assert any(
        f"{edited / 'goal.lp'}:4:" in r.getMessage() and "undefinedAtom" in r.getMessage()
        for r in caplog.records
    ), [r.getMessage() for r in caplog.records]


def test_the_shipped_encodings_ground_without_messages(caplog: pytest.LogCaptureFixture) -> None:
    facts, context = _facts()
    with caplog.at_level(logging.INFO, logger="planner.search.encoding"):
        encoding.ground(facts, 4, context)
        # Skipping a concern leaves atoms only it derives undefined: expected, not logged.
        encoding.ground(facts, 4, context, skip=("safety", "commonsense"))
    assert caplog.records == []


def test_an_unknown_concern_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown concern"):
        encoding.encoding_files(skip=("safty",))
