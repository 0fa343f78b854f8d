"""The Scenario panel: choose or open a scenario, edit its parts, save it.

What the panel decides is in `OpenScenario`, apart from the widgets: the name
the "Scenario" choice shows for what is loaded, what a load, an edit or a save
changes and the line it says. A scenario opened or edited goes to the stage
(another bench, the shown plan dropped: it was made for the scenario before)
and is announced on `Events` (`ScenarioChanged`). While an execution runs the
panel is locked. See stage.py for the panel pattern.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import viser

from app.dashboard import scenario_edit
from app.dashboard.scenario_edit import Loaded
from app.dashboard.scenario_folders import RefusedName, ScenarioFolders
from app.dashboard.stage import (
    Events,
    ExecutionFinished,
    ExecutionStarted,
    ScenarioChanged,
    Stage,
)
from app.dashboard.widgets import show
from planner.scenario.model import Scenario

# The "Scenario" choice while a file that no choice names is loaded (a path given
# on the command line outside the scenario folders, or shadowed by a user's file).
OTHER_FILE = "(another file)"
SAFETY = ("relaxed", "normal", "strict")
VERBOSITY = ("terse", "normal", "chatty")

Atomic = Callable[[], AbstractContextManager[None]]


@dataclass(frozen=True)
class Offer:
    """The "Scenario" choice: the name it shows and the names it offers."""

    value: str
    options: list[str]


@dataclass(frozen=True)
class Edits:
    """The panel's fields, as the page has them now."""

    safety: str
    verbosity: str
    dangerous: dict[str, bool] = field(default_factory=dict)
    region: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Change:
    """What a load or an edit did: `scenario` is the new one to show (None: the
    previous one stays, with its plan), `error` the panel's line (None: as it was)."""

    scenario: Scenario | None
    error: str | None


@dataclass(frozen=True)
class Saved:
    """What "Save" did (`ok`: a new file in the user's folder) and the line it says."""

    ok: bool
    line: str


class Control(Protocol):
    """A widget that can be switched off."""

    disabled: bool


def offer(folders: ScenarioFolders, source: str | None) -> Offer:
    """The folders' names, the one standing for `source` (a name the page asked
    for, or a file's path) chosen; `OTHER_FILE`, offered first, where none does."""
    names = folders.names()
    name = None
    if source is not None:
        name = source if source in names else folders.name_of(Path(source))
    if name is not None and name in names:
        return Offer(name, names)
    return Offer(OTHER_FILE, [OTHER_FILE, *names])


class OpenScenario:
    """The scenario the page works on, without its widgets: the last good load,
    the name offered for it, its edits and its saves."""

    def __init__(self, folders: ScenarioFolders) -> None:
        self.folders = folders
        self.loaded: Loaded | None = None
        self.offered: str | None = None  # the choice naming what is loaded
        self.saved_text: str | None = None  # the text as it was loaded or last saved

    @property
    def unsaved(self) -> bool:
        """The page's edits differ from the file loaded (or last saved)."""
        return self.loaded is not None and self.loaded.text != self.saved_text

    def offer(self) -> Offer:
        chosen = offer(self.folders, self.loaded.source if self.loaded else None)
        self.offered = chosen.value
        return chosen

    def is_new_choice(self, value: str) -> bool:
        """False for the choice `offer` set: that one is loaded already."""
        return value != self.offered

    def take(self, loaded: Loaded) -> Change:
        """A load: a scenario that does not load leaves the previous one."""
        if loaded.scenario is None:
            return Change(None, f"**Error:** {loaded.error}")
        self.loaded = loaded
        self.saved_text = loaded.text
        return Change(loaded.scenario, "")

    def edit(self, edits: Edits) -> Change:
        """An edit of the loaded scenario; one that changes nothing keeps its plan."""
        if self.loaded is None or self.loaded.scenario is None:
            return Change(None, None)
        changed = scenario_edit.edit(
            self.loaded.text, self.loaded.source, safety=edits.safety,
            verbosity=edits.verbosity, dangerous=edits.dangerous, region=edits.region,
        )  # fmt: skip
        if changed.text == self.loaded.text:
            return Change(None, None)
        if changed.scenario is None:
            return Change(None, f"**Error:** {changed.error}")
        self.loaded = changed  # the file as loaded stays `saved_text`
        return Change(changed.scenario, "")

    def save(self, name: str) -> Saved | None:
        """The loaded text saved as `name` in the user's folder (None: nothing loaded).
        What is loaded stays as it was: a file outside the folders is still
        `OTHER_FILE`, though the choice now offers the saved copy too."""
        if self.loaded is None:
            return None
        try:
            out = self.folders.save(self.loaded.text, name)
        except RefusedName as err:
            return Saved(False, f"**Error:** {err}")
        except OSError as err:
            return Saved(False, f"**Error:** cannot save in your scenario folder: {err.strerror}")
        self.saved_text = self.loaded.text
        return Saved(True, f"Saved as `{out.name}` in your scenario folder.")


PartInputs = tuple[viser.GuiDropdownHandle[str], viser.GuiCheckboxHandle]


class ScenarioPanel:
    """`atomic`: a context in which the page applies the panel's changes together."""

    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        events: Events,
        folders: ScenarioFolders,
        atomic: Atomic = nullcontext,
    ) -> None:
        self.gui = gui
        self.stage = stage
        self.events = events
        self.atomic = atomic
        self.scenario = OpenScenario(folders)
        self.executing = False
        self._turn = threading.RLock()  # one load, edit or save at a time
        self._showing = False  # the panel itself sets its fields to a loaded scenario
        self.part_inputs: dict[str, PartInputs] = {}
        with gui.add_folder("Scenario"):
            names = folders.names()
            self.pick = gui.add_dropdown("Scenario", names, initial_value=names[0])
            self.pick.on_update(lambda _: self._picked())
            self.path_text = gui.add_text("File", "")
            self.open_button = gui.add_button("Open file")
            self.open_button.on_click(lambda _: self.open_named(self.path_text.value))
            self.error = gui.add_markdown("")
            self.unsaved = gui.add_markdown("")
            self.safety = gui.add_dropdown("Safety", SAFETY)
            self.verbosity = gui.add_dropdown("Verbosity", VERBOSITY)
            self.safety.on_update(lambda _: self._edited())
            self.verbosity.on_update(lambda _: self._edited())
            self.parts_folder = gui.add_folder("Parts", expand_by_default=False)
            self.save_name = gui.add_text("Save as", "my-scenario.toml")
            self.save_button = gui.add_button("Save")
            self.save_button.on_click(lambda _: self.save())
        events.subscribe(ExecutionStarted, lambda _: self._lock(True))
        events.subscribe(ExecutionFinished, lambda _: self._lock(False))

    @property
    def loaded(self) -> Loaded | None:
        return self.scenario.loaded

    def open_file(self, path: str | Path) -> None:
        """The command line's scenario: any file the user running the server named."""
        self.show_loaded(scenario_edit.load_file(path))

    def open_named(self, name: str) -> None:
        """A scenario the page asked for: only from the scenario folders."""
        if self.executing:
            return  # the controls are disabled; a late event changes nothing
        self.show_loaded(scenario_edit.load_named(self.scenario.folders, name))

    def show_loaded(self, loaded: Loaded) -> None:
        with self._turn:
            self._show_loaded(loaded)

    def _show_loaded(self, loaded: Loaded) -> None:
        change = self.scenario.take(loaded)
        self.error.content = change.error or ""
        if change.scenario is None:
            if self.loaded is not None:
                self._offer()  # the choice goes back to what stays loaded
            return  # the previous scenario stays on screen, and usable
        scenario = change.scenario
        with self.atomic():
            self._offer()
            # Fields set to what was loaded are no edit of it (viser calls their
            # update callbacks for changes made here too).
            self._showing = True
            try:
                show(self.safety, scenario.preferences.safety)
                show(self.verbosity, scenario.preferences.verbosity)
            finally:
                self._showing = False
        self._rebuild_part_inputs(scenario)
        self._mark_unsaved()
        self.stage.show_scenario(scenario)
        self.events.publish(ScenarioChanged(scenario))

    def _mark_unsaved(self) -> None:
        loaded = self.loaded
        self.unsaved.content = (
            f"✎ **Unsaved edits** of `{loaded.source}`: **Save** keeps them as a new file."
            if loaded is not None and self.scenario.unsaved
            else ""
        )

    def _offer(self) -> None:
        """The offered name is recorded first and the value always stays among the
        options, so that neither change reads as a choice (`_picked`)."""
        chosen = self.scenario.offer()
        if chosen.value == OTHER_FILE:
            self.pick.options = chosen.options
            show(self.pick, chosen.value)
        else:
            show(self.pick, chosen.value)
            self.pick.options = chosen.options

    def _picked(self) -> None:
        if self.scenario.is_new_choice(self.pick.value):
            self.open_named(self.pick.value)

    def _rebuild_part_inputs(self, scenario: Scenario) -> None:
        for region_input, danger_input in self.part_inputs.values():
            region_input.remove()
            danger_input.remove()
        self.part_inputs = {}
        regions = [r.id for r in scenario.regions]
        with self.parts_folder:
            for part in scenario.parts:
                where = self.gui.add_dropdown(
                    f"{part.id} region", regions, initial_value=part.region
                )
                danger = self.gui.add_checkbox(f"{part.id} dangerous", part.dangerous)
                where.on_update(lambda _: self._edited())
                danger.on_update(lambda _: self._edited())
                self.part_inputs[part.id] = (where, danger)

    def edits(self) -> Edits:
        inputs = self.part_inputs.items()
        return Edits(
            self.safety.value,
            self.verbosity.value,
            dangerous={pid: danger.value for pid, (_, danger) in inputs},
            region={pid: where.value for pid, (where, _) in inputs},
        )

    def _edited(self) -> None:
        if self.executing or self._showing:
            return
        with self._turn:
            self._take_edits()

    def _take_edits(self) -> bool:
        """The page's fields as they are now, applied to the loaded scenario; False
        if they make no valid scenario (the line says why)."""
        change = self.scenario.edit(self.edits())
        if change.error is not None:
            self.error.content = change.error
        if change.scenario is not None:
            self._mark_unsaved()
            self.stage.show_scenario(change.scenario)
            self.events.publish(ScenarioChanged(change.scenario, edited=True))
        return not change.error

    def save(self) -> None:
        """The loaded scenario as a file of the user's folder ("Save as"), with every
        edit the page's fields show (one clicked just before may still be on its way)."""
        if self.executing:
            return
        with self._turn:
            if not self._take_edits():
                return  # the page shows an edit that is refused: its line stays
            saved = self.scenario.save(self.save_name.value)
            if saved is None:
                return
            if saved.ok:
                self._offer()
            self._mark_unsaved()
            self.error.content = saved.line

    def _lock(self, locked: bool) -> None:
        """While an execution runs nobody may change the scenario under it."""
        self.executing = locked
        parts: list[Control] = [h for pair in self.part_inputs.values() for h in pair]
        controls: list[Control] = [
            self.pick, self.path_text, self.open_button, self.safety, self.verbosity,
            self.save_name, self.save_button, *parts,
        ]  # fmt: skip
        with self.atomic():
            for handle in controls:
                handle.disabled = locked

    def close(self) -> None:
        """Nothing runs in the panel's own threads."""
