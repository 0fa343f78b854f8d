"""Scenario edits made in the page, applied to the TOML text and validated again.

Edits change the file's own text (tomlkit keeps its comments, key order and
the way it writes arrays): a saved scenario is the file that was loaded with
only the edited values changed, and an edit undone gives the file back as it
was. Validation errors are the planner's one-line `ScenarioError`s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import tomlkit
from tomlkit.exceptions import TOMLKitError
from tomlkit.items import AbstractTable

from app.dashboard.region_move import NoFreeSpot, free_spot
from app.dashboard.scenario_folders import RefusedName, ScenarioFolders
from planner.feasibility.scene import part_boxes, region_extents
from planner.resources import find_scenario
from planner.scenario.loading import ScenarioError, load_scenario, parse_scenario
from planner.scenario.model import Scenario

# What a scenario means when it leaves a key out (planner/scenario/sections.py): an
# edit back to it writes no new key.
DEFAULTS = {"safety": "normal", "verbosity": "normal", "dangerous": False}


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
    """The scenario with the given changes. A part moved to another region stands
    where the planner will read it: at a free spot of its new region among parts
    placed by pose (`region_move`), or without a pose where its new region's parts
    have none (the layout's grid places them all)."""
    before = load_text(text, source).scenario
    try:
        doc = tomlkit.parse(text)
    except TOMLKitError as err:
        return Loaded(text, source, None, f"{source}: not TOML: {err}")
    prefs = doc.get("preferences")
    for key, value in (("safety", safety), ("verbosity", verbosity)):
        if value is None or (prefs is None and value == DEFAULTS[key]):
            continue
        if prefs is None:
            prefs = doc["preferences"] = tomlkit.table()
        _set(prefs, key, value)
    parts = doc.get("parts", [])
    for part in parts:
        pid = part.get("id")
        if dangerous and pid in dangerous:
            _set(part, "dangerous", dangerous[pid])
    for part in parts:
        pid = part.get("id")
        if region and pid in region and region[pid] != part.get("region"):
            part["region"] = region[pid]
            try:
                _stand(part, before, parts)
            except NoFreeSpot as err:
                return Loaded(text, source, None, f"{source}: {err}")
    return load_text(tomlkit.dumps(doc), source)


def _set(table: AbstractTable, key: str, value: object) -> None:
    """`key = value` in `table`, in its place; a value a missing key already means is
    not written, so an edit undone leaves the text as it was."""
    if key in table:
        if table[key] != value:
            table[key] = value
    elif value != DEFAULTS.get(key):
        table[key] = value


def _stand(part: AbstractTable, before: Scenario | None, parts: Sequence[AbstractTable]) -> None:
    """Gives a part just moved to `part["region"]` the pose the planner should read
    (see `edit`); `before` is the scenario before the edit (None: it did not load)."""
    pid, where = part["id"], part["region"]
    others = [p for p in parts if p.get("id") != pid]
    extents = region_extents(before) if before is not None else {}
    grid = any("pose" not in p for p in others if p.get("region") == where)
    if before is None or where not in extents or grid or all("pose" not in p for p in others):
        part.pop("pose", None)  # laid out with its region's other parts, or refused later
        return
    boxes = part_boxes(before)
    # The moved part stays inside its region; there, every other part has a pose (the
    # grid of another region stays inside that region).
    placed = {
        str(p["id"]): replace(boxes[p["id"]], x=float(p["pose"][0]), y=float(p["pose"][1]),
                              yaw=float(p["pose"][2]), region=str(p.get("region")))
        for p in others if "pose" in p and p.get("id") in boxes
    }  # fmt: skip
    part["pose"] = free_spot(boxes[pid], extents[where], where, placed).pose()
