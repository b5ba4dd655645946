"""Silencing what pybullet's C code prints (build banner, ``argv[0]=``) on the process's stdout/stderr."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def quiet_fd(fd: int) -> Iterator[None]:
    """Send what is written to file descriptor ``fd`` (1 or 2) to /dev/null inside the block.

    Python's own ``sys.stdout``/``sys.stderr`` are flushed first, so nothing
    written before the block is lost.
    """
    (sys.stdout if fd == 1 else sys.stderr).flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)
