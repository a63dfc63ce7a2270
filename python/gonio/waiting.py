"""client.scan.wait: returns when a scan ends, with a progress bar.

It subscribes to the scan's progress first and reads the scan after, so no change falls
between the two; it reads the scan again every few seconds as well, so a notification
lost to a reconnect delays nothing. The bar is gonioctl's (`scan watch`): on a terminal
redrawn in place, in Jupyter a text output updated in place (no widget library needed),
elsewhere (a log, a pipe) nothing unless progress=True.
"""
from __future__ import annotations

import math
import sys
import time

from .client import TERMINAL_STATES, checked_params
from .errors import ScanNotCompleted

RECHECK_S = 5.0


def bar_text(done: int, total: int, eta_s: float | None = None, diverged: int = 0, width: int = 30) -> str:
    """"[##########··········]  45/81   56 %  ETA 0:12  diverged 2", as gonioctl draws it."""
    frac = min(1.0, done / total) if total else 0.0
    filled = int(frac * width + 1e-9)
    eta = "0:00" if done >= total else _duration(eta_s)
    return (f"[{'#' * filled}{'·' * (width - filled)}] {done:>{len(str(total))}}/{total}  "
            f"{100 * frac:3.0f} %  ETA {eta}  diverged {diverged}")


def _duration(s: float | None) -> str:
    if s is None or not math.isfinite(s) or s < 0:
        return "-"
    t = round(s)
    return f"{t // 3600}:{t // 60 % 60:02d}:{t % 60:02d}" if t >= 3600 else f"{t // 60}:{t % 60:02d}"


class _Bar:
    """Where the bar goes: a Jupyter output, a terminal, or nowhere."""

    def __init__(self, enabled: bool | None):
        self._handle, self._tty = None, False
        if enabled is False:
            return
        if _in_jupyter():
            from IPython.display import display
            self._handle = display(_Text(""), display_id=True)
        elif enabled or sys.stderr.isatty():
            self._tty = True

    def show(self, text: str) -> None:
        if self._handle is not None:
            self._handle.update(_Text(text))
        elif self._tty:
            sys.stderr.write("\r" + text + "\x1b[K")
            sys.stderr.flush()

    def end(self, text: str) -> None:
        self.show(text)
        if self._tty:
            sys.stderr.write("\n")


class _Text:
    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


def _in_jupyter() -> bool:
    if "ipykernel" not in sys.modules:
        return False
    try:
        from IPython import get_ipython
        return get_ipython() is not None and hasattr(get_ipython(), "kernel")
    except ImportError:
        return False


def _line(sc: dict, eta_s=None) -> str:
    text = bar_text(sc.get("points_done", 0), sc.get("points_total", 0), eta_s, sc.get("points_diverged", 0))
    return f"scan {sc.get('id')} {sc.get('state')}  " + text


def wait(client, *, scan: int, timeout: float | None = None, progress: bool | None = None,
         check: bool = True) -> dict:
    """Waits until scan `scan` ends (completed, failed or cancelled) and returns its record
    (scan.get). timeout: seconds (None: no limit; TimeoutError when it passes). progress:
    the bar (None: on a terminal and in Jupyter). check: raise gonio.ScanNotCompleted when
    it ended other than completed."""
    spec = _get_spec()
    checked_params(spec, {"scan": scan})
    end = None if timeout is None else time.monotonic() + timeout
    bar = _Bar(progress)
    with client.subscribe("scan.progress", "scan.state", scan=scan) as sub:
        sc = client._call("scan.get", {"scan": scan}, None, True)
        eta, last_read = None, time.monotonic()
        while sc["state"] not in TERMINAL_STATES:
            bar.show(_line(sc, eta))
            left = RECHECK_S if end is None else min(RECHECK_S, end - time.monotonic())
            if left <= 0:
                raise TimeoutError(f"scan {scan} is still {sc['state']} after {timeout} s")
            note = sub.next(timeout=left)
            if note is not None and note.params.get("scan") == scan:
                sc = {**sc, **{k: v for k, v in note.params.items() if k != "scan"}}
                eta = note.params.get("eta_s", eta)
            if note is None or sc["state"] in TERMINAL_STATES or time.monotonic() - last_read > RECHECK_S:
                sc, last_read = client._call("scan.get", {"scan": scan}, None, True), time.monotonic()
    bar.end(_line(sc))
    if check and sc["state"] != "completed":
        raise ScanNotCompleted(sc)
    return sc


def _get_spec():
    from . import schema
    return schema.methods()["scan.get"]


def wait_method():
    """client.scan.wait (not a JSON-RPC method: the client's own, on scan.get and subscribe)."""
    def method(self, *, scan: int, timeout: float | None = None, progress: bool | None = None,
               check: bool = True) -> dict:
        return wait(self._client, scan=scan, timeout=timeout, progress=progress, check=check)
    method.__doc__ = wait.__doc__
    method.__name__, method.__qualname__ = "wait", "scan.wait"
    return method
