"""A study day on the dashboard: executions watched by pages leave memory flat.

The pages are real websocket clients of the dashboard's viser server
(`WatchingPage`): they receive everything a browser would, render nothing, and
every ten executions one leaves and a new one joins. Answers go through the
execution panel's click source, as the simulated-human buttons do.
"""

from __future__ import annotations

import time

from app.benchmark.memory import BOUND_MB, MemoryRun, WatchingPage, replayed, run_day, table
from app.benchmark.memory import watched_dashboard as dashboard_on_default

EXECUTIONS = 100
PAGES = 2
# Without the robot's meshes: the pages get every message but the meshes' 5 MB,
# and the test stays within CI's minutes (`python -m app.benchmark.memory` has them).
MODELS = False


def test_a_hundred_executions_watched_by_two_pages_keep_the_server_flat() -> None:
    with dashboard_on_default(models=MODELS) as dashboard:
        run: MemoryRun = run_day(dashboard, EXECUTIONS, PAGES)
        # A page joining after the day is sent what one joining before it was.
        late = WatchingPage(dashboard.server.get_port())
        end = time.monotonic() + 30
        while not dashboard.server.get_clients() and time.monotonic() < end:
            time.sleep(0.01)  # until the server has greeted it
        assert len(dashboard.server.get_clients()) == 1
        late.close()
        kept = sum(replayed(dashboard.server).values())
    print()
    print(table(run, PAGES))
    first, last = run.after_warm_up()
    print(f"RSS per execution over the last {last.execution - first.execution}: "
          f"{run.per_execution_kb():.1f} KB")  # fmt: skip
    assert run.results == {"goal": EXECUTIONS}
    assert run.reconnects == EXECUTIONS // 10 and last.pages == PAGES
    # Nothing piles up in the replay buffer: removed elements leave nothing behind.
    assert last.replayed <= first.replayed + 10, (first, last)
    assert kept <= first.replayed + 10
    assert run.growth_mb() <= BOUND_MB, table(run, PAGES)
