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

from app.dashboard.scenario_folders import RefusedName, ScenarioFolders
from planner.resources import find_scenario
from planner.scenario.loading import ScenarioError, load_scenario, parse_scenario
from planner.scenario.model import Scenario


@dataclass
class Loaded:
    """A scenario as text and as a validated model (None with `error` when invalid).

    `source` is how the page names it; errors say what is wrong without quoting
    the file (`ScenarioError.without_value`).
    """

    text: str
    source: str
    scenario: Scenario | None
    error: str = ""


def load_file(path: str | Path, source: str | None = None) -> Loaded:
    """The scenario at `path` (the command line's, or one found in the scenario
    folders); `source` names it on the page (default: the path)."""
    path = find_scenario(path)
    shown = str(path) if source is None else source
    try:
        scenario = load_scenario(path)
    except ScenarioError as err:
        return Loaded("", shown, None, f"{shown}: {err.field}: {err.message}")
    return Loaded(path.read_text(), shown, scenario)


def load_named(folders: ScenarioFolders, name: str) -> Loaded:
    """A scenario the page asked for by name, read only from the allowed folders."""
    try:
        path = folders.find(name.strip())
    except RefusedName as err:
        return Loaded("", name, None, str(err))
    return load_file(path, name.strip())


def load_text(text: str, source: str) -> Loaded:
    try:
        return Loaded(text, source, parse_scenario(text, source))
    except ScenarioError as err:
        return Loaded(text, source, None, err.without_value())


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
