"""Kill a child process midway through its runs: how far its results store has got, read
while the child writes it, and a SIGKILL once it is far enough (the kill-and-resume tests)."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path


def store_progress(path: Path) -> tuple[int, int]:
    """Evaluations and checkpoints in the results store ``path`` so far (0, 0 before it
    exists)."""
    if not path.is_file():
        return 0, 0
    conn = sqlite3.connect(path, timeout=10)
    try:
        evals = conn.execute("SELECT count(*) FROM evaluations").fetchone()[0]
        ckpts = conn.execute("SELECT count(*) FROM checkpoints").fetchone()[0]
    except sqlite3.OperationalError:  # tables not created yet
        return 0, 0
    finally:
        conn.close()
    return evals, ckpts


def kill_midway(command: Sequence[str], store: Path, evals: int, checkpoints: int,
                timeout: float = 120.0) -> int:
    """Run ``command``, SIGKILL it once ``store`` holds ``evals`` evaluations and
    ``checkpoints`` checkpoints, and return its exit code (−SIGKILL when killed midway)."""
    # its own session, so that SIGKILL reaches it and its worker processes at once
    child = subprocess.Popen(list(command), start_new_session=True)
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and child.poll() is None:
            done, ckpts = store_progress(store)
            if done >= evals and ckpts >= checkpoints:
                os.killpg(child.pid, signal.SIGKILL)
                break
            time.sleep(0.01)
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
        child.wait(timeout=30)
    return child.returncode
