"""The dashboard's "Solve on" setting: a plan solved by Ray actors, chosen in the page."""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("playwright.sync_api")
ray = pytest.importorskip("ray", reason="Ray is not installed: pip install 'tandem[cluster]'")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.plan_panel import RAY  # noqa: E402
from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from planner.planning import plan_scenario  # noqa: E402
from tests.plan_fixtures import ROOT, free_port, tandem_command  # noqa: E402
from tests.test_dashboard import field, open_page, wait_for  # noqa: E402, F401


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    d = Dashboard(
        "127.0.0.1",
        free_port(),
        "declared.toml",
        DashboardSettings(
            workers=2,
            cache_dir=str(tmp_path_factory.mktemp("cache")),
            data_dir=str(tmp_path_factory.mktemp("data")),
        ),
    )
    yield d
    d.close()
    # The cluster the page started is this process's: leave none to later tests.
    ray.shutdown()


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    page = open_page(browser, dashboard)
    yield page
    page.close()


def _without_timings(doc: dict[str, Any]) -> dict[str, Any]:
    doc["stats"] = {k: v for k, v in doc["stats"].items() if not k.endswith("_s")}
    return doc


def _plan_from_the_page(page: Page, dashboard: Dashboard) -> str:
    before = dashboard.job
    page.get_by_role("button", name="Plan", exact=True).click()
    wait_for(lambda: dashboard.job is not before, 30)
    wait_for(lambda: dashboard.job is not None and dashboard.job.status.state != "planning", 180)
    assert dashboard.job is not None
    return dashboard.job.status.message


def test_a_plan_solved_on_ray_actors_is_the_local_plan(page: Page, dashboard: Dashboard) -> None:
    # Choose the Ray cluster in the page; its address field opens for editing.
    assert field(page, "Ray address").is_disabled()  # type: ignore[attr-defined]
    field(page, "Solve on").click()  # type: ignore[attr-defined]
    page.get_by_role("option", name=RAY, exact=True).click()
    wait_for(lambda: dashboard.plan_panel.solve_on.value == RAY, 10)
    wait_for(lambda: not field(page, "Ray address").is_disabled(), 10)  # type: ignore[attr-defined]
    assert dashboard.cluster == "auto"
    message = _plan_from_the_page(page, dashboard)
    if message.startswith("no cluster"):
        pytest.skip(f"a local Ray cluster cannot start here: {message}")
    assert dashboard.job is not None and dashboard.job.status.state == "done", message
    assert ray.is_initialized()  # the page's plan started the local cluster
    planned = dashboard.job.plan
    assert planned is not None and len(planned.nodes) > 20
    # The scenario the page planned, planned here by two local worker processes.
    assert dashboard.loaded is not None and dashboard.loaded.scenario is not None
    assert dashboard.loaded.scenario.name == "paper-base-declared"
    local = plan_scenario(dashboard.loaded.scenario, workers=2).plan
    assert _without_timings(planned.to_json()) == _without_timings(local.to_json())


def test_a_bad_address_fails_the_plan_in_one_line(page: Page, dashboard: Dashboard) -> None:
    if dashboard.plan_panel.solve_on.value != RAY:  # as the test before left it, or not
        field(page, "Solve on").click()  # type: ignore[attr-defined]
        page.get_by_role("option", name=RAY, exact=True).click()
    address = field(page, "Ray address")
    wait_for(lambda: not address.is_disabled(), 10)  # type: ignore[attr-defined]
    address.fill("localhost:6379")  # type: ignore[attr-defined]
    address.press("Enter")  # type: ignore[attr-defined]
    wait_for(lambda: dashboard.plan_panel.ray_address.value == "localhost:6379", 10)
    message = _plan_from_the_page(page, dashboard)
    assert dashboard.job is not None and dashboard.job.status.state == "failed"
    assert message == "no cluster: --cluster 'localhost:6379': expected auto or ray://HOST:PORT"
    page.get_by_text(message, exact=True).wait_for()
    assert not dashboard.plan_panel.plan_button.disabled  # the page can plan again


def test_the_command_refuses_a_bad_address_before_it_starts() -> None:
    done = subprocess.run(
        [*tandem_command(), "dashboard", "--cluster", "head:10001", "--port", str(free_port())],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2, done
    assert done.stderr.strip().splitlines() == [
        "--cluster 'head:10001': expected auto or ray://HOST:PORT"
    ]
