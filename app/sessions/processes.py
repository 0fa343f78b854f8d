"""Is the process that ran a session still running? Pid, start time and boot id."""

from __future__ import annotations

import os
from pathlib import Path

# A live process that started this many seconds after a session did is not its owner.
PID_START_SLACK_S = 2.0


def boot_id() -> str | None:
    try:
        return Path("/proc/sys/kernel/random/boot_id").read_text().strip() or None
    except OSError:
        return None


def process_start(pid: int) -> float | None:
    """When process `pid` started (seconds since the epoch), from /proc; None if unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        boot = next(
            float(line.split()[1])
            for line in Path("/proc/stat").read_text().splitlines()
            if line.startswith("btime ")
        )
    except (OSError, StopIteration, ValueError, IndexError):
        return None
    # Field 22 (starttime, in clock ticks since boot) counts after the ")" ending the name.
    fields = stat.rsplit(")", 1)[-1].split()
    try:
        ticks = int(fields[19])
    except (IndexError, ValueError):
        return None
    return boot + ticks / os.sysconf("SC_CLK_TCK")


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process, alive
    except OSError:
        return False
    return True


def owner_alive(pid: int | None, started: float, host_boot: str | None) -> bool:
    """Whether the process that ran a session (started at `started`) still runs."""
    if pid is None:
        return False
    current_boot = boot_id()
    if host_boot and current_boot and host_boot != current_boot:
        return False  # the machine rebooted since
    if not pid_alive(pid):
        return False
    begun = process_start(pid)
    return begun is None or begun <= started + PID_START_SLACK_S
