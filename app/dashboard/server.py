"""The dashboard: one viser server with the bench, the plan tree and the panels.

The `Dashboard` only composes (stage.py says how): it creates the viser
server, the `Screen` (the panels' `Stage`), the `Events` bus and the panels,
each given the GUI API, the stage and the bus. Its methods are the entry the
command line, the benchmarks and the tests use; each hands over to the panel
or the stage that does it.
"""

from __future__ import annotations

import errno
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import viser

from app.dashboard.bench_scene import BenchScene
from app.dashboard.camera_panel import CameraPanel
from app.dashboard.execution_panel import ExecutionPanel
from app.dashboard.layout import GUIDE, Layout
from app.dashboard.mesh_detail import DEFAULT_DETAIL
from app.dashboard.node_panel import NodePanel
from app.dashboard.operator import Operator
from app.dashboard.plan_panel import PlanPanel, PlanSettings
from app.dashboard.planning_job import PlanningJob
from app.dashboard.review_panel import ReviewPanel
from app.dashboard.robot_panel import RobotPanel
from app.dashboard.scenario_edit import Loaded
from app.dashboard.scenario_folders import RECORDINGS_FOLDER, USER_FOLDER, ScenarioFolders
from app.dashboard.scenario_panel import ScenarioPanel
from app.dashboard.screen import Screen
from app.dashboard.speech_panel import Speak, SpeechPanel
from app.dashboard.stage import Events
from app.dashboard.tree_svg import Step
from app.dashboard.tree_view import TreeView
from app.dashboard.view_panel import ViewPanel
from app.sessions.database import StoreError
from app.sessions.store import SessionStore, default_data_dir
from planner.plan.model import Plan
from planner.scenario.model import Scenario


def _serve(host: str, port: int) -> viser.ViserServer:
    server = viser.ViserServer(host=host, port=port, label="Tandem", verbose=False)
    if port != 0 and server.get_port() != port:
        # viser moves on to the next free port; a user who asked for this one
        # (a bookmark, a tunnel, a firewall rule) must hear that it is taken.
        server.stop()
        raise OSError(errno.EADDRINUSE, f"port {port} is in use")
    server.scene.configure_default_lights(cast_shadow=False)
    # No image-based lighting: a browser without a GPU drew each frame of the bench
    # in ~350 ms with it and ~165 ms without (measured in headless Chromium on U10),
    # and every frame holds the page, a click in the tree included.
    server.scene.configure_environment_map(None)
    server.gui.configure_theme(control_width="large", show_logo=False)
    return server


@dataclass(frozen=True)
class DashboardSettings:
    """How a dashboard plans, where it keeps its data, and what it draws and plays.

    `workers` and `cluster` are the planner's (0: this machine's default; a Ray
    address), `cache_dir` the feasibility checks' cache, `data_dir` the session
    store and the user's scenarios, `scenario_dirs` more folders to offer,
    `load_models` whether to draw the robot's meshes (tests skip them), and
    `speak` where the robot's voice plays.
    """

    workers: int = 0
    cluster: str | None = None
    cache_dir: str | None = None
    data_dir: str | None = None
    scenario_dirs: Sequence[str | Path] = ()
    load_models: bool = True
    mesh_detail: float = DEFAULT_DETAIL
    speak: Speak = "page"


class Dashboard:
    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8080,
        scenario_path: str = "default.toml",
        settings: DashboardSettings | None = None,
    ) -> None:
        s = settings if settings is not None else DashboardSettings()
        data = Path(s.data_dir) if s.data_dir is not None else default_data_dir()
        self.folders = ScenarioFolders(data / USER_FOLDER, [Path(p) for p in s.scenario_dirs])
        self.server = server = _serve(host, port)
        self.events = events = Events()
        self.operator = Operator()
        gui = server.gui
        # Panels first, in the page's order: a new page gets messages in creation
        # order, so it can be used while the robot's meshes (~5 MB) still arrive.
        # The layout (layout.py): set-up, plan and review on the left, above the
        # camera; the tree and the selected node on the right, above the execution.
        panels = Layout(gui)
        with panels.tree_tab:  # the tree, and the selected node right under it
            self.screen = screen = Screen(server, events)
            self.node_panel = NodePanel(gui, screen, events)
            screen.tree.add_find_controls()
        screen.tree.on_width = panels.widen_tree
        gui.add_markdown(GUIDE)
        # Plan above the scenario's fields: its status names the scenario loaded, and
        # its button shows on a new page without scrolling (1280×800 included).
        self.plan_panel = PlanPanel(
            gui, screen, events, PlanSettings(s.workers, s.cache_dir, s.cluster)
        )
        self.scenario_panel = ScenarioPanel(gui, screen, events, self.folders, server.atomic)
        self.view_panel = ViewPanel(gui, screen, events, lambda: server.get_clients().values())
        panels.add_restore_button(gui)  # under View: each page's own layout
        try:
            self.store = SessionStore(data)
        except StoreError:
            server.stop()
            raise
        self.speech = SpeechPanel(gui, screen, events, s.speak)
        self.robot = RobotPanel(gui, screen)
        with panels.execution_tab:
            self.robot.add_fault_controls()  # above the execution's own controls
            self.execution = ExecutionPanel(
                gui, screen, events, self.store, self.operator, self.speech.responses,
                self.robot,
            )  # fmt: skip
        if self.store.read_only is not None:
            self.execution.refuse_executions(self.store.read_only)
        with panels.review_tab:
            self.review = ReviewPanel(gui, screen, events, self.store)
        with panels.camera_tab:
            self.camera_panel = CameraPanel(
                gui, screen, events, self.operator, data / RECORDINGS_FOLDER,
                panels.camera_tab,
            )  # fmt: skip
        self.layout = panels
        if s.load_models:
            screen.bench.load_models(s.mesh_detail)
        server.on_client_connect(self.view_panel.greet)
        server.on_client_connect(self.camera_panel.windows.greet)  # its own Enlarge box
        server.on_client_disconnect(self.camera_panel.windows.leave)
        self.open_scenario(scenario_path)

    # -- what the panels and the stage hold -------------------------------------------

    @property
    def bench(self) -> BenchScene:
        return self.screen.bench

    @property
    def tree(self) -> TreeView:
        return self.screen.tree

    @property
    def plan(self) -> Plan | None:
        """The plan on screen, complete or still being built."""
        return self.screen.plan

    @plan.setter
    def plan(self, plan: Plan | None) -> None:
        self.screen.plan = plan

    @property
    def selected(self) -> str | None:
        return self.screen.selected

    @property
    def loaded(self) -> Loaded | None:
        return self.scenario_panel.loaded

    @property
    def job(self) -> PlanningJob | None:
        return self.plan_panel.job

    @property
    def cluster(self) -> str | None:
        """The Ray address the next plan is solved on; None: on this machine."""
        return self.plan_panel.cluster

    # -- the panels' actions ------------------------------------------------------------

    def open_scenario(self, path: str | Path) -> None:
        """The command line's scenario: any file the user running the server named."""
        self.scenario_panel.open_file(path)

    def open_named(self, name: str) -> None:
        """A scenario the page asked for: only from the scenario folders."""
        self.scenario_panel.open_named(name)

    def show_loaded(self, loaded: Loaded) -> None:
        self.scenario_panel.show_loaded(loaded)

    def start_planning(self) -> None:
        self.plan_panel.start_planning()

    def camera(self, view: str, client: viser.ClientHandle | None = None) -> None:
        self.view_panel.aim(view, client)

    # -- the stage (stage.Stage), as the screen shows it ------------------------------------

    def current_plan(self) -> Plan | None:
        return self.screen.current_plan()

    def current_scenario(self) -> Scenario | None:
        return self.screen.current_scenario()

    def show_plan(self, plan: Plan) -> None:
        self.screen.show_plan(plan)

    def select(self, node_id: str, *, show_world: bool = True) -> None:
        self.screen.select(node_id, show_world=show_world)

    def go_to(
        self, node_id: str, *, show_world: bool = True, path: tuple[Step, ...] | None = None
    ) -> None:
        self.screen.go_to(node_id, show_world=show_world, path=path)

    def show_world(self, node_id: str) -> None:
        self.screen.show_world(node_id)

    def arms(self) -> dict[str, list[float]]:
        return self.screen.arms()

    def show_arms(self, arms: Mapping[str, list[float]]) -> None:
        self.screen.show_arms(arms)

    def close(self, reason: str | None = None) -> None:
        """Stops everything; a running execution ends `interrupted` with `reason`
        when the program is stopping (a signal), else aborted."""
        self.plan_panel.close()
        self.robot.give_up()  # a question after a robot fault must not hold the close
        self.execution.close(reason)
        self.robot.close()
        for panel in (self.review, self.camera_panel, self.speech, self.scenario_panel,
                      self.node_panel, self.view_panel):  # fmt: skip
            panel.close()
        self.events.clear()
        self.server.stop()
        self.store.close()
