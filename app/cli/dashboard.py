"""`tandem dashboard`: the browser dashboard on a scenario."""

from __future__ import annotations

import argparse
import time

from app.cli.exit_codes import BadInput


def register(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=8080, help="port (default 8080)")
    parser.add_argument(
        "--scenario",
        default="default.toml",
        help="scenario file, or a shipped one: default.toml, paper/U10.toml",
    )
    parser.add_argument("--workers", type=int, default=0, help="planner processes (0: all cores)")
    parser.add_argument(
        "--data-dir",
        help="where sessions are stored (default: $TANDEM_DATA_DIR or ~/.local/share/tandem)",
    )
    parser.add_argument(
        "--speak",
        choices=["page", "local"],
        default="page",
        help="where the robot's voice plays: in the browser page (default) or on this "
        "machine's speakers",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    # Imported here: viser and the robot meshes load only for this command.
    from app.dashboard.server import Dashboard

    try:
        dashboard = Dashboard(
            args.host,
            args.port,
            args.scenario,
            workers=args.workers,
            data_dir=args.data_dir,
            speak=args.speak,
        )
    except OSError as err:
        raise BadInput(
            f"dashboard: cannot listen on {args.host}:{args.port}: {err.strerror or err}"
        ) from err
    print(f"Tandem dashboard on http://{args.host}:{args.port}  (Ctrl-C to stop)", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        dashboard.close()
    return 0
