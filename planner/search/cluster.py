"""Ray as the distributed engine (optional: `pip install tandem[cluster]`).

Nothing here imports Ray at module load: `import planner.search.cluster` costs nothing,
and a run without `--cluster` never loads Ray. `connect("auto")` joins the Ray
cluster this machine belongs to, or starts a local one; `ray://HOST:PORT` goes
through Ray Client to a remote head.

- `BranchActors`: stateful actors, each grounding the program once and solving
  many states (the multi-shot pattern of the local worker processes); the
  frontier goes to the least busy actor and `hcp.ConditionalPlanner` integrates
  results in request order, so the plan does not depend on the number of actors.
- `map_tasks`: one Ray task per item (sweeps), results in the items' order;
  `as_completed_tasks` yields them as each task ends (studies store each at once).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from planner.search.branch_planner import BranchResult, Problem
    from planner.vocabulary import State

T = TypeVar("T")
R = TypeVar("R")


class ClusterUnavailable(RuntimeError):
    """Ray is not installed, or the cluster cannot be reached."""


def _ray() -> Any:
    try:
        import ray
    except ImportError as err:
        raise ClusterUnavailable(
            "--cluster needs Ray: pip install 'tandem[cluster]'"
        ) from err
    return ray


def check_address(address: str) -> None:
    """Refuses what cannot be a Ray address, before anything waits for it."""
    if address != "auto" and not address.startswith("ray://"):
        raise ClusterUnavailable(f"--cluster {address!r}: expected auto or ray://HOST:PORT")


# The address `connect` last joined in this process; None if Ray was started by
# its caller (a test, a notebook), whose cluster is then used as it is.
_joined: str | None = None


def connect(address: str, *, num_cpus: int | None = None) -> None:
    """Joins (or, for "auto" with no cluster running, starts) the Ray cluster at `address`.

    A process that joined another address leaves it first (the dashboard's
    setting may change between plans). `num_cpus` bounds a cluster started here
    (tests start a small one)."""
    global _joined
    ray = _ray()
    check_address(address)
    if ray.is_initialized():
        if _joined in (None, address):
            return
        ray.shutdown()
        _joined = None
    try:
        if address == "auto":
            try:
                ray.init(address="auto", log_to_driver=False)
            except ConnectionError:
                # No cluster on this machine: a local one, for this run only.
                ray.init(num_cpus=num_cpus, log_to_driver=False, include_dashboard=False)
        else:
            ray.init(address=address, log_to_driver=False)
    except Exception as err:  # Ray raises many types; each one means "no cluster"
        raise ClusterUnavailable(f"cannot reach the Ray cluster at {address}: {err}") from err
    _joined = address


def cluster_cpus() -> int:
    """The CPUs the connected cluster offers (at least 1)."""
    return max(1, int(_ray().cluster_resources().get("CPU", 1)))


def map_tasks(function: Callable[[T], R], items: Sequence[T]) -> list[R]:
    """`function` on every item as a Ray task (one CPU each); results in `items` order."""
    ray = _ray()
    remote = ray.remote(num_cpus=1)(function)
    return list(ray.get([remote.remote(item) for item in items]))


def as_completed_tasks(function: Callable[[T], R], items: Sequence[T]) -> Iterator[R]:
    """`function` on every item as a Ray task (one CPU each); each result as its task
    ends. Left early (an error, Ctrl-C), the tasks not yet ended are cancelled."""
    ray = _ray()
    remote = ray.remote(num_cpus=1)(function)
    waiting = [remote.remote(item) for item in items]
    try:
        while waiting:
            ended, waiting = ray.wait(waiting, num_returns=1)
            yield ray.get(ended[0])
    finally:
        for ref in waiting:
            ray.cancel(ref, force=True)


class _Actor:
    """One actor's state: a branch planner (`planner.search.branch_planner`), grounded
    once per horizon."""

    def __init__(self, problem: Problem) -> None:
        from planner.search.branch_planner import BranchPlanner  # the local workers' own

        self.planner = BranchPlanner(problem)

    def branch(self, start: State, forbid: frozenset[str]) -> BranchResult:
        return self.planner.branch(start, forbid)


class BranchActors:
    """`count` actors solving branches of one problem; `submit` gives a Future."""

    def __init__(self, problem: Problem, count: int) -> None:
        ray = _ray()
        actor = ray.remote(num_cpus=1)(_Actor)
        self._actors = [actor.remote(problem) for _ in range(count)]
        self._busy = [0] * count
        self._ray = ray

    def submit(self, state: State, forbid: frozenset[str]) -> Future[BranchResult]:
        # The least busy actor (the first of them on a tie): requests spread evenly
        # while each actor keeps its grounded programs.
        i = min(range(len(self._actors)), key=self._busy.__getitem__)
        self._busy[i] += 1
        future: Future[BranchResult] = self._actors[i].branch.remote(state, forbid).future()

        def done(_: Future[BranchResult], i: int = i) -> None:
            self._busy[i] -= 1

        future.add_done_callback(done)
        return future

    def close(self) -> None:
        for a in self._actors:
            self._ray.kill(a)
        self._actors = []
