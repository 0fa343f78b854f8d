"""The dashboard: one viser server with the bench, the plan tree and the panels.

The `Dashboard` is the panels' `Stage` (stage.py): it owns the scene and the
tree, and hands each panel the GUI API, itself as a stage, and the events bus.
"""

from __future__ import annotations

import errno
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import viser

from app.dashboard import scenario_edit
from app.dashboard.bench_scene import BenchScene
from app.dashboard.camera_panel import CameraPanel
from app.dashboard.execution_panel import ExecutionPanel
from app.dashboard.mesh_detail import DEFAULT_DETAIL
from app.dashboard.node_details import details_markdown, stats_html
from app.dashboard.operator import Operator
from app.dashboard.planning_job import JobStatus, PlanningJob, partial_plan
from app.dashboard.review_panel import ReviewPanel
from app.dashboard.scenario_folders import (
    RECORDINGS_FOLDER,
    USER_FOLDER,
    RefusedName,
    ScenarioFolders,
)
from app.dashboard.speech_panel import Speak, SpeechPanel
from app.dashboard.stage import (
    Events,
    ExecutionFinished,
    ExecutionStarted,
    PlanChanged,
    ScenarioChanged,
)
from app.dashboard.tree_view import WALL_X, TreeView
from app.execution.world import world_at
from app.sessions.database import StoreError
from app.sessions.store import SessionStore, default_data_dir
from planner.plan.model import Plan, PlanNode
from planner.scenario.model import Scenario

# The "Scenario" choice while a file that no choice names is loaded (a path given
# on the command line outside the scenario folders, or shadowed by a user's file).
OTHER_FILE = "(another file)"
# The choices of "Solve on".
HERE = "this machine"
RAY = "a Ray cluster"
LIVE_REDRAW_S = 0.5  # at most two redraws of the growing tree per second
CAMERAS = {
    "Bench": ((2.6, -1.5, 0.9), (0.7, 0.0, -0.2)),
    "Robot view": ((-0.4, 0.0, 0.6), (1.0, 0.0, -0.3)),
    "Human view": ((2.2, 0.0, 0.5), (0.6, 0.0, -0.2)),
    "Top": ((0.85, -0.01, 2.6), (0.85, 0.0, -0.05)),
}


class Dashboard:
    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8080,
        scenario_path: str = "default.toml",
        *,
        workers: int = 0,
        cluster: str | None = None,
        cache_dir: str | None = None,
        data_dir: str | None = None,
        scenario_dirs: Sequence[str | Path] = (),
        load_models: bool = True,
        mesh_detail: float = DEFAULT_DETAIL,
        speak: Speak = "page",
    ) -> None:
        data = Path(data_dir) if data_dir is not None else default_data_dir()
        self.folders = ScenarioFolders(data / USER_FOLDER, [Path(p) for p in scenario_dirs])
        self.server = viser.ViserServer(host=host, port=port, label="Tandem", verbose=False)
        if port != 0 and self.server.get_port() != port:
            # viser moves on to the next free port; a user who asked for this one
            # (a bookmark, a tunnel, a firewall rule) must hear that it is taken.
            self.server.stop()
            raise OSError(errno.EADDRINUSE, f"port {port} is in use")
        self.server.scene.configure_default_lights(cast_shadow=False)
        self.server.gui.configure_theme(control_width="large", show_logo=False)
        self.workers = workers
        self._cluster_default = cluster
        self.cache_dir = cache_dir
        self.loaded: scenario_edit.Loaded | None = None
        self._offered: str | None = None  # the "Scenario" choice naming what is loaded
        self.executing = False
        self.job: PlanningJob | None = None
        self.plan: Plan | None = None
        self.selected: str | None = None
        self.events = Events()
        self.operator = Operator()
        self._last_live = 0.0
        self._lock = threading.Lock()
        # Panels first: a new page gets messages in creation order, so it can be used
        # while the robot's meshes (~5 MB) are still arriving.
        self._build_gui()
        try:
            self.store = SessionStore(data)
        except StoreError:
            self.server.stop()
            raise
        gui = self.server.gui
        self.speech = SpeechPanel(gui, self, self.events, speak)
        self.execution = ExecutionPanel(
            gui, self, self.events, self.store, self.operator, self.speech.responses
        )
        if self.store.read_only is not None:
            self.execution.refuse_executions(self.store.read_only)
        self.review = ReviewPanel(gui, self, self.events, self.store)
        self.events.subscribe(ExecutionStarted, lambda _: self._lock_scenario(True))
        self.events.subscribe(ExecutionFinished, lambda _: self._lock_scenario(False))
        self.camera_panel = CameraPanel(
            gui, self, self.events, self.operator, data / RECORDINGS_FOLDER
        )
        self.bench = BenchScene(
            self.server, load_models=load_models, mesh_detail=mesh_detail
        )
        self.tree = TreeView(self.server, self.select)
        self.current_arms: dict[str, list[float]] = {}
        self.server.on_client_connect(self._on_connect)
        self.open_scenario(scenario_path)

    # -- panels -----------------------------------------------------------------

    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.add_markdown("**Tandem**: plans for a robot and a human building a table")
        with gui.add_folder("Scenario"):
            names = self.folders.names()
            self.pick: Any = gui.add_dropdown("Scenario", names, initial_value=names[0])
            self.pick.on_update(lambda _: self._picked())
            self.path_text = gui.add_text("File", "")
            self.open_button = gui.add_button("Open file")
            self.open_button.on_click(lambda _: self.open_named(self.path_text.value))
            self.error = gui.add_markdown("")
            # Any: viser's types mark `.value` read-only on these handles, yet setting
            # it is how a server changes what the page shows.
            self.safety: Any = gui.add_dropdown("Safety", ["relaxed", "normal", "strict"])
            self.verbosity: Any = gui.add_dropdown("Verbosity", ["terse", "normal", "chatty"])
            self.safety.on_update(lambda _: self._edited())
            self.verbosity.on_update(lambda _: self._edited())
            self.parts_folder = gui.add_folder("Parts", expand_by_default=False)
            self._part_inputs: dict[str, tuple[Any, Any]] = {}
            self.save_name = gui.add_text("Save as", "my-scenario.toml")
            self.save_button = gui.add_button("Save")
            self.save_button.on_click(lambda _: self._save())
        with gui.add_folder("Plan"):
            # Where branches are solved: this machine's processes, or Ray actors
            # (`tandem plan --cluster`); the address is kept while "this machine".
            self.solve_on: Any = gui.add_dropdown(
                "Solve on",
                [HERE, RAY],
                initial_value=RAY if self._cluster_default else HERE,
                hint="Ray needs tandem[cluster]; auto joins this machine's cluster or starts one",
            )
            self.ray_address: Any = gui.add_text(
                "Ray address",
                self._cluster_default or "auto",
                disabled=not self._cluster_default,
                hint="auto, or ray://HOST:PORT of a cluster's head",
            )
            self.solve_on.on_update(
                lambda _: setattr(self.ray_address, "disabled", self.solve_on.value != RAY)
            )
            self.plan_button = gui.add_button("Plan", color="green")
            self.plan_button.on_click(lambda _: self.start_planning())
            self.cancel_button = gui.add_button("Cancel", disabled=True)
            self.cancel_button.on_click(lambda _: self.job.cancel() if self.job else None)
            self.progress: Any = gui.add_progress_bar(0.0)
            self.status = gui.add_markdown("Not planned yet.")
            self.stats = gui.add_html("")
        self.node_folder = gui.add_folder("Selected node")
        with self.node_folder:
            self.details = gui.add_markdown("Click a node of the plan tree.")
            self.toggle_button = gui.add_button("Collapse / expand", disabled=True)
            self.toggle_button.on_click(lambda _: self._toggle())
            self.parent_button = gui.add_button("Parent", disabled=True)
            self.parent_button.on_click(lambda _: self._to_parent())
            self.children_group: Any = None
        with gui.add_folder("View"):
            views = gui.add_button_group("Camera", [*CAMERAS, "Plan tree", "Selected"])
            views.on_click(lambda event: self.camera(event.target.value, event.client))

    def _scenario_controls(self) -> list[Any]:
        parts = [handle for pair in self._part_inputs.values() for handle in pair]
        return [
            self.pick, self.path_text, self.open_button, self.safety, self.verbosity,
            self.save_name, self.save_button, self.solve_on, self.plan_button, *parts,
        ]  # fmt: skip

    def _lock_scenario(self, locked: bool) -> None:
        """While an execution runs nobody may change the scenario or the plan under it."""
        self.executing = locked
        with self.server.atomic():
            for handle in self._scenario_controls():
                handle.disabled = locked
        if not locked and self.job is not None and self.job.running:
            self.plan_button.disabled = True

    def _on_connect(self, client: viser.ClientHandle) -> None:
        self.camera("Bench", client)

    def camera(self, view: str, client: viser.ClientHandle | None = None) -> None:
        clients = [client] if client is not None else list(self.server.get_clients().values())
        if view in CAMERAS:
            position, target = CAMERAS[view]
        elif self.tree.current is None:
            return
        elif view == "Selected" and self.selected in self.tree.current.positions:
            x, y, z = self.tree.world(self.selected)
            position, target = (x - 1.2, y, z), (x, y, z)
        else:
            y, z, width, height = self.tree.centre()
            distance = max(2.0, 0.9 * max(width, height * 1.6))
            position, target = (WALL_X - distance, y, z), (WALL_X, y, z)
        for c in clients:
            with c.atomic():
                c.camera.position = position
                c.camera.look_at = target

    # -- scenario -----------------------------------------------------------------

    def open_scenario(self, path: str | Path) -> None:
        """The command line's scenario: any file the user running the server named."""
        self.show_loaded(scenario_edit.load_file(path))

    def open_named(self, name: str) -> None:
        """A scenario the page asked for: only from the scenario folders."""
        if self.executing:
            return  # the controls are disabled; a late event changes nothing
        self.show_loaded(scenario_edit.load_named(self.folders, name))

    def _offer_scenarios(self) -> None:
        """The scenario folders' names as choices, the loaded one chosen (`OTHER_FILE`
        where no name stands for it). The value is set before the options, so that
        neither change reads as a choice (`_picked`)."""
        names = self.folders.names()
        name = None
        if self.loaded is not None:
            source = self.loaded.source  # a name the page asked for, or a file's path
            name = source if source in names else self.folders.name_of(Path(source))
        self._offered = name if name in names else OTHER_FILE
        if self._offered == OTHER_FILE:
            self.pick.options = [OTHER_FILE, *names]
            self.pick.value = OTHER_FILE
        else:
            self.pick.value = self._offered
            self.pick.options = names

    def _picked(self) -> None:
        # The choice set by _offer_scenarios is what is loaded already.
        if self.pick.value != self._offered:
            self.open_named(self.pick.value)

    def show_loaded(self, loaded: scenario_edit.Loaded) -> None:
        if loaded.scenario is None:
            self.error.content = f"**Error:** {loaded.error}"
            if self.loaded is not None:
                self._offer_scenarios()  # the choice goes back to what stays loaded
            return  # the previous scenario stays on screen, and usable
        self.error.content = ""
        self.loaded = loaded
        scenario = loaded.scenario
        self.bench.load(scenario)
        with self.server.atomic():
            self._offer_scenarios()
            self.safety.value = scenario.preferences.safety
            self.verbosity.value = scenario.preferences.verbosity
        self._rebuild_part_inputs()
        self.plan = None
        self.events.publish(PlanChanged(None))
        self.events.publish(ScenarioChanged(scenario))
        self.status.content = f"Scenario **{scenario.name}** ({len(scenario.parts)} parts)."

    def _rebuild_part_inputs(self) -> None:
        assert self.loaded is not None and self.loaded.scenario is not None
        for region_input, danger_input in self._part_inputs.values():
            region_input.remove()
            danger_input.remove()
        self._part_inputs = {}
        regions = [r.id for r in self.loaded.scenario.regions]
        with self.parts_folder:
            for part in self.loaded.scenario.parts:
                where = self.server.gui.add_dropdown(
                    f"{part.id} region", regions, initial_value=part.region
                )
                danger = self.server.gui.add_checkbox(f"{part.id} dangerous", part.dangerous)
                where.on_update(lambda _: self._edited())
                danger.on_update(lambda _: self._edited())
                self._part_inputs[part.id] = (where, danger)

    def _edited(self) -> None:
        if self.loaded is None or self.loaded.scenario is None or self.executing:
            return
        changed = scenario_edit.edit(
            self.loaded.text,
            self.loaded.source,
            safety=self.safety.value,
            verbosity=self.verbosity.value,
            dangerous={pid: d.value for pid, (_, d) in self._part_inputs.items()},
            region={pid: r.value for pid, (r, _) in self._part_inputs.items()},
        )
        if changed.text == self.loaded.text:
            return
        if changed.scenario is None:
            self.error.content = f"**Error:** {changed.error}"
            return
        self.error.content = ""
        self.loaded = changed
        self.bench.load(changed.scenario)
        # The shown plan was made for the scenario before the edit: not to be executed.
        self.plan = None
        self.events.publish(PlanChanged(None))
        self.events.publish(ScenarioChanged(changed.scenario))
        self.status.content = "Scenario changed: plan again."

    def _save(self) -> None:
        if self.loaded is None:
            return
        try:
            out = self.folders.save(self.loaded.text, self.save_name.value)
        except RefusedName as err:
            self.error.content = f"**Error:** {err}"
            return
        except OSError as err:
            self.error.content = f"**Error:** cannot save in your scenario folder: {err.strerror}"
            return
        self._offer_scenarios()
        self.error.content = f"Saved as `{out.name}` in your scenario folder."

    # -- planning -----------------------------------------------------------------

    def start_planning(self) -> None:
        if self.loaded is None or self.loaded.scenario is None or self.executing:
            return
        if self.job is not None and self.job.running:
            return
        self.plan_button.disabled = True
        self.cancel_button.disabled = False
        self.stats.content = ""
        # Planning again drops the shown plan, so nobody executes it meanwhile.
        self.plan = None
        self.events.publish(PlanChanged(None))
        self.job = PlanningJob(
            self.loaded.scenario,
            self._job_changed,
            workers=self.workers,
            cache_dir=self.cache_dir,
            cluster=self.cluster,
        )
        self.job.start()

    @property
    def cluster(self) -> str | None:
        """The Ray address the next plan is solved on; None: on this machine."""
        if self.solve_on.value != RAY:
            return None
        return str(self.ray_address.value).strip() or "auto"

    def _job_changed(self, status: JobStatus) -> None:
        job = self.job
        self.progress.value = 100.0 * (status.fraction if status.state == "planning" else 1.0)
        if status.state == "planning":
            self.status.content = (
                f"Planning: {status.done} nodes done, {status.open} open ({status.seconds:.1f} s)"
            )
            now = time.perf_counter()
            if (
                job is not None
                and job.planner is not None
                and now - self._last_live > LIVE_REDRAW_S
            ):
                self._last_live = now
                partial = partial_plan(job.planner, job.scenario)
                if partial is not None:
                    with self._lock:
                        self.plan = partial
                        self.tree.show(partial)
            return
        self.plan_button.disabled = False
        self.cancel_button.disabled = True
        self.status.content = status.message
        if status.state == "done" and job is not None and job.plan is not None:
            self.show_plan(job.plan)
            self.camera("Plan tree")

    # -- the stage the panels drive (stage.Stage) ------------------------------------

    def current_plan(self) -> Plan | None:
        return self.plan

    def current_scenario(self) -> Scenario | None:
        return self.loaded.scenario if self.loaded is not None else None

    def show_plan(self, plan: Plan) -> None:
        """A complete plan (planned here or stored with a session) in the tree and panels."""
        with self._lock:
            self.plan = plan
            self.tree.show(plan)
        self.stats.content = stats_html(plan)
        self.select(plan.root)
        self.events.publish(PlanChanged(plan))

    def arms(self) -> dict[str, list[float]]:
        return dict(self.current_arms)

    def show_arms(self, arms: Mapping[str, list[float]]) -> None:
        self.bench.show_arms(dict(arms))

    # -- the selected node ----------------------------------------------------------

    def select(self, node_id: str, *, show_world: bool = True) -> None:
        """Show a node: its details, and the bench as the node leaves it (a node
        hidden in a collapsed branch stays hidden: `go_to` opens it)."""
        with self._lock:
            plan, tree = self.plan, self.tree.tree
            if plan is None or tree is None or node_id not in plan.nodes:
                return
            self.selected = node_id
            lineage = tree.lineage(node_id)
            node = plan.nodes[node_id]
            self.details.content = details_markdown(node_id, node)
            self.tree.highlight(node_id)
            if show_world:
                self._show_world(plan, lineage)
            self.toggle_button.disabled = not node.children
            self.parent_button.disabled = len(lineage) < 2
            self._child_buttons(node)

    def show_world(self, node_id: str) -> None:
        """The bench as `node_id` leaves it (after an arm's motion has been played)."""
        with self._lock:
            if self.plan is not None and self.tree.tree is not None:
                self._show_world(self.plan, self.tree.tree.lineage(node_id))

    def _show_world(self, plan: Plan, lineage: list[str]) -> None:
        world = world_at(
            plan.nodes, lineage, self.bench.boxes, human_edge_x=self.bench.human_edge_x
        )
        self.bench.show(world)
        self.current_arms = world.arms

    def _child_buttons(self, node: PlanNode) -> None:
        if self.children_group is not None:
            self.children_group.remove()
            self.children_group = None
        kids = node.children
        if not kids:
            return
        labels = [k.outcome or "next" for k in kids]
        targets = {label: k.node for label, k in zip(labels, kids, strict=True)}
        with self.node_folder:
            self.children_group = self.server.gui.add_button_group("Go to", labels)
        self.children_group.on_click(lambda e: self._go(targets[e.target.value]))

    def go_to(self, node_id: str, *, show_world: bool = True) -> None:
        """Open every collapsed ancestor of `node_id`, then select it."""
        if self.tree.tree is not None and node_id in self.tree.tree.depth:
            self.tree.expand_to(node_id)
        self.select(node_id, show_world=show_world)

    def _go(self, node_id: str) -> None:
        self.go_to(node_id)

    def _toggle(self) -> None:
        if self.selected is not None:
            self.tree.toggle(self.selected)
            self.tree.highlight(self.selected)

    def _to_parent(self) -> None:
        if self.selected is not None and self.tree.tree is not None:
            lineage = self.tree.tree.lineage(self.selected)
            if len(lineage) > 1:
                self.select(lineage[-2])

    def close(self, reason: str | None = None) -> None:
        """Stops everything; a running execution ends `interrupted` with `reason`
        when the program is stopping (a signal), else aborted."""
        if self.job is not None:
            self.job.cancel()
        self.execution.close(reason)
        for panel in (self.review, self.camera_panel, self.speech):
            panel.close()
        self.events.clear()
        self.server.stop()
        self.store.close()
