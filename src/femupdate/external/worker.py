"""The process that holds one external model: ``python -m femupdate.external.worker FD LOG``.

Started by :class:`femupdate.external.isolation.IsolatedModel`, it talks to its parent over the
socket ``FD`` (a ``multiprocessing`` connection: pickled tuples) and writes everything the
model prints to ``LOG``. It holds one model, loaded once, and answers one request at a time:

- ``("init", model, ag, dt, sys_path)`` → ``("ready",)`` or ``("config", kind, message)``;
- ``("predict", values)`` or ``("frequencies", values)`` → ``("ok", array)`` or
  ``("fail", message)`` (or ``("config", kind, message)`` for a ConfigError);
- ``("stop",)``, or the parent going away → the process removes ``LOG`` and exits.

A hung model is the parent's to kill: this process never limits time itself.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
import traceback
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

#: How often the watchdog looks for its parent (s).
WATCH_INTERVAL_S = 0.5
#: Characters of the model's output quoted in a failure message.
OUTPUT_TAIL = 300


def output_tail(log: str, start: int, limit: int = OUTPUT_TAIL) -> str:
    """What the model printed to ``log`` since byte ``start``, its last ``limit`` characters
    on one line (empty if nothing)."""
    try:
        with open(log, "rb") as f:
            f.seek(start)
            text = f.read().decode(errors="replace")
    except OSError:
        return ""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    joined = " | ".join(lines)
    return joined if len(joined) <= limit else "…" + joined[-limit:]


def describe(exc: BaseException) -> str:
    """``Type: message (file.py:line in function)`` at the innermost frame of the traceback."""
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    frames = traceback.extract_tb(exc.__traceback__)
    if frames:
        last = frames[-1]
        text += f" ({os.path.basename(last.filename)}:{last.lineno} in {last.name})"
    return text


def _watch_parent(parent: int) -> None:
    """Exit when the parent process is gone (a model stuck in Python code would outlive it)."""
    while True:
        time.sleep(WATCH_INTERVAL_S)
        if os.getppid() != parent:
            os._exit(3)


def _config_reply(exc: BaseException) -> tuple[str, str, str]:
    from femupdate.errors import ConfigError, MissingDependencyError

    kind = "MissingDependencyError" if isinstance(exc, MissingDependencyError) else "ConfigError"
    message = str(exc) if isinstance(exc, ConfigError | MissingDependencyError) else describe(exc)
    return ("config", kind, message)


def _answer(model: Any, request: tuple[Any, ...], ag: np.ndarray, dt: float,
            log: str) -> tuple[Any, ...]:
    from femupdate.errors import ConfigError, MissingDependencyError

    kind, values = request[0], request[1]
    start = os.path.getsize(log) if os.path.exists(log) else 0
    try:
        if kind == "predict":
            out = model.predict(values, ag.copy(), dt)
        elif kind == "frequencies":
            out = model.frequencies(values)
        else:
            return ("fail", f"unknown request {kind!r}")
    except (ConfigError, MissingDependencyError) as exc:
        return _config_reply(exc)
    except BaseException as exc:  # the user's code: SystemExit and all
        message = describe(exc)
        sys.stdout.flush()
        sys.stderr.flush()
        tail = output_tail(log, start)
        return ("fail", f"{message}; model output: {tail}" if tail else message)
    # An array of numbers pickles safely; anything else is named, not sent.
    if out is None:
        return ("ok", None)
    if np.iscomplexobj(out):  # a float conversion would drop the imaginary part
        return ("fail", "the model returned complex values (allowed: real numbers, e.g. the "
                        "real part taken on purpose)")
    try:
        return ("ok", np.asarray(out, dtype=float))
    except (TypeError, ValueError) as exc:
        return ("fail", f"the model returned {type(out).__name__}, not an array of numbers "
                        f"({exc})")


def serve(conn: Connection, log: str) -> None:
    """Load the model of the first request, then answer until told to stop."""
    init = conn.recv()
    _, model, ag, dt, sys_path = init
    sys.path[:0] = [p for p in sys_path if p not in sys.path]
    try:
        model.prepare()
    except BaseException as exc:
        conn.send(_config_reply(exc))
        return
    conn.send(("ready",))
    while True:
        try:
            request = conn.recv()
        except (EOFError, OSError):
            return
        if request[0] == "stop":
            return
        reply = _answer(model, request, ag, dt, log)
        sys.stdout.flush()
        sys.stderr.flush()
        try:
            conn.send(reply)
        except (TypeError, AttributeError, ValueError) as exc:  # could not pickle the result
            conn.send(("fail", f"the result could not be sent back: {describe(exc)}"))


def main(argv: list[str]) -> int:
    """Entry point: ``worker FD LOG``."""
    fd, log = int(argv[1]), argv[2]
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()
    conn = Connection(fd)
    try:
        serve(conn, log)
    except (EOFError, OSError):
        pass
    finally:
        conn.close()
    # Stopped or orphaned, not crashed: nobody will quote the log (its parent may not be able
    # to remove it: pool and Dask workers exit without atexit handlers).
    with contextlib.suppress(OSError):
        os.unlink(log)
    # Skip interpreter teardown: some extensions (OpenSees) print or hang when unloaded.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
