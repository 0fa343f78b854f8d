"""The dashboard: one viser server with the bench, the plan tree and the panels.

The `Dashboard` is the panels' `Stage` (stage.py): it owns the scene and the
tree, and hands each panel the GUI API, itself as a stage, and the events bus.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from typing import Any

import viser

from app.dashboard import scenario_edit
from app.dashboard.bench_scene import BenchScene
from app.dashboard.execution_panel import ExecutionPanel
from app.dashboard.node_details import details_markdown, stats_html
from app.dashboard.planning_job import JobStatus, PlanningJob, partial_plan
from app.dashboard.review_panel import ReviewPanel
from app.dashboard.speech_panel import Speak, SpeechPanel
from app.dashboard.stage import Events, PlanChanged
from app.dashboard.tree_view import WALL_X, TreeView
from app.dashboard.world import world_at
from app.store import SessionStore
from planner.plan import Plan, PlanNode

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
        cache_dir: str | None = None,
        data_dir: str | None = None,
        load_models: bool = True,
        speak: Speak = "page",
    ) -> None:
        self.server = viser.ViserServer(host=host, port=port, label="Tandem", verbose=False)
        self.server.scene.configure_default_lights(cast_shadow=False)
        self.server.gui.configure_theme(control_width="large", show_logo=False)
        self.workers = workers
        self.cache_dir = cache_dir
        self.loaded: scenario_edit.Loaded | None = None
        self.job: PlanningJob | None = None
        self.plan: Plan | None = None
        self.selected: str | None = None
        self.events = Events()
        self._last_live = 0.0
        self._lock = threading.Lock()
        # Panels first: a new page gets messages in creation order, so it can be used
        # while the robot's meshes (~5 MB) are still arriving.
        self._build_gui()
        self.store = SessionStore(data_dir)
        gui = self.server.gui
        self.speech = SpeechPanel(gui, self, self.events, speak)
        self.execution = ExecutionPanel(gui, self, self.events, self.store, self.speech.responses)
        self.review = ReviewPanel(gui, self, self.events, self.store)
        self.bench = BenchScene(self.server, load_models=load_models)
        self.tree = TreeView(self.server, self.select)
        self.current_arms: dict[str, list[float]] = {}
        self.server.on_client_connect(self._on_connect)
        self.open_scenario(scenario_path)

    # -- panels -----------------------------------------------------------------

    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.add_markdown("**Tandem**: plans for a robot and a human building a table")
        with gui.add_folder("Scenario"):
            names = scenario_edit.shipped_scenarios()
            self.pick = gui.add_dropdown("Scenario", names, initial_value=names[0])
            self.pick.on_update(lambda _: self.open_scenario(self.pick.value))
            self.path_text = gui.add_text("File", "")
            gui.add_button("Open file").on_click(lambda _: self.open_scenario(self.path_text.value))
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
            gui.add_button("Save").on_click(lambda _: self._save())
        with gui.add_folder("Plan"):
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

    def open_scenario(self, path: str) -> None:
        if not path.strip():
            self.error.content = "**Error:** give a scenario file path."
            return
        self.show_loaded(scenario_edit.load_file(path.strip()))

    def show_loaded(self, loaded: scenario_edit.Loaded) -> None:
        if loaded.scenario is None:
            self.error.content = f"**Error:** {loaded.error}"
            return  # the previous scenario stays on screen, and usable
        self.error.content = ""
        self.loaded = loaded
        scenario = loaded.scenario
        self.bench.load(scenario)
        with self.server.atomic():
            self.safety.value = scenario.preferences.safety
            self.verbosity.value = scenario.preferences.verbosity
        self._rebuild_part_inputs()
        self.plan = None
        self.events.publish(PlanChanged(None))
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
        if self.loaded is None or self.loaded.scenario is None:
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
        self.status.content = "Scenario changed: plan again."

    def _save(self) -> None:
        if self.loaded is None:
            return
        try:
            out = scenario_edit.save(self.loaded.text, self.save_name.value)
        except (ValueError, OSError) as err:
            self.error.content = f"**Error:** {err}"
            return
        self.error.content = f"Saved to `{out}`."

    # -- planning -----------------------------------------------------------------

    def start_planning(self) -> None:
        if self.loaded is None or self.loaded.scenario is None:
            return
        if self.job is not None and self.job.running:
            return
        self.plan_button.disabled = True
        self.cancel_button.disabled = False
        self.stats.content = ""
        self.job = PlanningJob(
            self.loaded.scenario, self._job_changed, workers=self.workers, cache_dir=self.cache_dir
        )
        self.job.start()

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
        world = world_at(plan.nodes, lineage, self.bench.boxes)
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

    def close(self) -> None:
        if self.job is not None:
            self.job.cancel()
        for panel in (self.execution, self.review, self.speech):
            panel.close()
        self.events.clear()
        self.server.stop()
        self.store.close()
