"""`tandem dashboard`: the browser dashboard on a scenario."""

from __future__ import annotations

import argparse
import ipaddress
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from app.cli.exit_codes import BadInput
from planner.search.cluster import check_address

REMOTE_WARNING = (
    "warning: the dashboard listens on {host}, beyond this machine. viser cannot refuse "
    "a connection, so anyone who reaches port {port} can plan, open shipped and saved "
    "scenarios, save new ones, and run and answer executions. Prefer --host 127.0.0.1 "
    "and an SSH tunnel (docs/security.md)."
)


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=8080, help="port (default 8080)")
    parser.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a --host other than loopback (anyone who reaches it drives the dashboard)",
    )
    parser.add_argument(
        "--scenario",
        default="default.toml",
        help="scenario file, or a shipped one: default.toml, paper/U10.toml",
    )
    parser.add_argument(
        "--scenario-dir",
        action="append",
        default=[],
        metavar="DIR",
        help="a folder the page may open scenarios from (repeatable; read-only)",
    )
    parser.add_argument("--workers", type=int, default=0, help="planner processes (0: all cores)")
    parser.add_argument(
        "--cluster",
        metavar="auto|ray://HOST:PORT",
        help='solve branches on Ray actors by default (the page\'s "Solve on" can change it; '
        "needs tandem[cluster])",
    )
    parser.add_argument(
        "--data-dir",
        help="where sessions and saved scenarios are stored "
        "(default: $TANDEM_DATA_DIR or ~/.local/share/tandem)",
    )
    parser.add_argument(
        "--speak",
        choices=["page", "local"],
        default="page",
        help="where the robot's voice plays: in the browser page (default) or on this "
        "machine's speakers",
    )
    parser.add_argument(
        "--mesh-detail",
        type=mesh_detail,
        default=0.1,
        metavar="SHARE",
        help="share of the robot's and the human's triangles drawn, in (0, 1] (default 0.1: "
        "light enough for a browser without a GPU; 1 draws the full meshes)",
    )
    parser.set_defaults(run=run)


def mesh_detail(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 < value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], not {text}")
    return value


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name: it may resolve beyond this machine


def run(args: argparse.Namespace) -> int:
    # Imported here: viser and the robot meshes load only for this command.
    from app.dashboard.server import Dashboard, DashboardSettings

    if not is_loopback(args.host):
        if not args.allow_remote:
            raise BadInput(
                f"dashboard: --host {args.host} is reachable from other machines; "
                "add --allow-remote if you mean it (docs/security.md)"
            )
        print(REMOTE_WARNING.format(host=args.host, port=args.port), file=sys.stderr, flush=True)
    if args.cluster is not None:
        check_address(args.cluster)  # ClusterUnavailable: exit 2, one line
    for folder in args.scenario_dir:
        if not Path(folder).is_dir():
            raise BadInput(f"--scenario-dir {folder}: not a folder")
    try:
        dashboard = Dashboard(
            args.host,
            args.port,
            args.scenario,
            DashboardSettings(
                workers=args.workers,
                cluster=args.cluster,
                data_dir=args.data_dir,
                scenario_dirs=args.scenario_dir,
                speak=args.speak,
                mesh_detail=args.mesh_detail,
            ),
        )
    except OSError as err:
        raise BadInput(
            f"dashboard: cannot listen on {args.host}:{args.port}: {err.strerror or err}"
        ) from err
    stop = threading.Event()
    stopped_by: list[str] = []

    def on_signal(number: int, _frame: FrameType | None) -> None:
        stopped_by.append(signal.Signals(number).name)
        stop.set()

    for number in (signal.SIGTERM, signal.SIGINT):
        signal.signal(number, on_signal)
    port = dashboard.server.get_port()
    print(f"Tandem dashboard on http://{args.host}:{port}  (Ctrl-C to stop)", flush=True)
    if dashboard.store.read_only is not None:
        print(f"review only: {dashboard.store.read_only}", file=sys.stderr, flush=True)
    stop.wait()
    dashboard.close(f"the dashboard stopped ({stopped_by[0]})")
    return 0
