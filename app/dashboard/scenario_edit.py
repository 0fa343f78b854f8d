"""Scenario edits made in the page, applied to the TOML text and validated again.

Edits go through the file's own data (tomllib in, tomli_w out), so what is saved
is a scenario file like any other, and validation errors are the planner's
one-line `ScenarioError`s.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tomli_w

from planner.resources import find_scenario, scenario_dir
from planner.scenario import ScenarioError, load_scenario, parse_scenario
from planner.scenario_model import Scenario

SCENARIO_DIR = scenario_dir()


@dataclass
class Loaded:
    """A scenario as text and as a validated model (None with `error` when invalid)."""

    text: str
    source: str
    scenario: Scenario | None
    error: str = ""


def shipped_scenarios() -> list[str]:
    """The shipped scenario files, relative names, default first."""
    names = sorted(str(p.relative_to(SCENARIO_DIR)) for p in SCENARIO_DIR.rglob("*.toml"))
    return sorted(names, key=lambda n: (n != "default.toml", n.count("/"), n))


def load_file(path: str | Path) -> Loaded:
    path = find_scenario(path)
    try:
        scenario = load_scenario(path)
    except ScenarioError as err:
        text = path.read_text(errors="replace") if path.is_file() else ""
        return Loaded(text, str(path), None, str(err))
    return Loaded(path.read_text(), str(path), scenario)


def load_text(text: str, source: str) -> Loaded:
    try:
        return Loaded(text, source, parse_scenario(text, source))
    except ScenarioError as err:
        return Loaded(text, source, None, str(err))


def edit(
    text: str,
    source: str,
    *,
    safety: str | None = None,
    verbosity: str | None = None,
    dangerous: dict[str, bool] | None = None,
    region: dict[str, str] | None = None,
) -> Loaded:
    """The scenario with the given changes; a part moved to another region loses
    its pose (the layout places it inside the new region)."""
    data: dict[str, Any] = tomllib.loads(text)
    prefs = data.setdefault("preferences", {})
    if safety is not None:
        prefs["safety"] = safety
    if verbosity is not None:
        prefs["verbosity"] = verbosity
    for part in data.get("parts", []):
        pid = part.get("id")
        if dangerous and pid in dangerous:
            part["dangerous"] = dangerous[pid]
        if region and pid in region and region[pid] != part.get("region"):
            part["region"] = region[pid]
            part.pop("pose", None)
    return load_text(tomli_w.dumps(data), source)


def save(text: str, path: str | Path) -> Path:
    """Write a validated scenario to a new file; refuses to overwrite one."""
    out = Path(path)
    if out.suffix != ".toml":
        raise ValueError(f"{out}: a scenario file name ends in .toml")
    if out.exists():
        raise ValueError(f"{out}: exists already; choose a new name")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return out
