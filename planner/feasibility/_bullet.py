"""pybullet, imported and used without its C-level chatter on stdout.

pybullet prints its build time on import and link names while loading a URDF
straight to the process's stdout, which would corrupt the CLI's table; every
module of this package imports `pb` from here.
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def silenced() -> Iterator[None]:
    """Send file descriptors 1 and 2 to /dev/null, flushing C's buffers before restoring."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        ctypes.CDLL(None).fflush(None)  # C stdio buffers still point at /dev/null
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


with silenced():
    import pybullet as pb

__all__ = ["pb", "silenced"]
