"""Exceptions: one class per JSON-RPC error code of goniod, made from openrpc.json.

goniod answers a failed call with a JSON-RPC error whose code has a fixed meaning
(proto/errors.md) and whose data carries the stable gonio::Errc id (`errc`) and the
offending input (`field`). Each code is a subclass of RpcError named as in the document's
x-error-codes (gonio.PlanRejected, gonio.Unauthorized, gonio.InvalidParams, ...), so a
script catches what it can handle:

    try:
        client.scan.submit(sample="tile", grids="in=95;out=0")
    except gonio.InvalidParams as e:
        print(e.field, e.errc, e)      # grid.in out_of_range grid.in = 95 is outside ...

Failures of the link itself are ConnectionLost (and RequestTimeout when no answer came in
time); they are not JSON-RPC errors and have no code.
"""
from __future__ import annotations

from . import schema


class GonioError(Exception):
    """Every error this package raises."""


class RpcError(GonioError):
    """An error answer of goniod. code: the JSON-RPC code; errc: the stable gonio::Errc id
    (proto/errors.md); field: the offending parameter when known ("geometries[3].theta_r");
    method: the method called."""

    code: int = 0

    def __init__(self, message: str, *, code: int | None = None, errc: str | None = None,
                 field: str | None = None, method: str | None = None, data: dict | None = None):
        super().__init__(message)
        self.message = message
        if code is not None:
            self.code = code
        self.errc = errc
        self.field = field
        self.method = method
        self.data = data or {}

    def __str__(self) -> str:
        s = self.message
        if self.field:
            s += f" [field {self.field}]"
        return s + f" ({self.code}{', ' + self.errc if self.errc else ''})"


class ConnectionLost(GonioError, ConnectionError):
    """goniod could not be reached, or the link dropped. sent: whether the request had been
    sent (a method that changes state may then have been done)."""

    def __init__(self, message: str, *, sent: bool = False):
        super().__init__(message)
        self.sent = sent


class RequestTimeout(GonioError, TimeoutError):
    """No answer within the call's timeout (the request was sent; the link stays up and a late
    answer is dropped)."""


class TlsError(GonioError):
    """goniod's certificate could not be verified (tls://, https://): not retried."""


class ScanNotCompleted(GonioError):
    """scan.wait: the scan ended other than completed (failed or cancelled). scan: its
    final record (state, reason)."""

    def __init__(self, scan: dict):
        super().__init__(f"scan {scan.get('id')} ended {scan.get('state')}"
                         + (f": {scan['reason']}" if scan.get("reason") else ""))
        self.scan = scan


def _make_classes() -> dict[int, type[RpcError]]:
    by_code = {}
    for e in schema.error_codes():
        cls = type(e["name"], (RpcError,), {"code": e["code"], "__doc__": e["meaning"],
                                            "__module__": __name__})
        globals()[e["name"]] = cls
        by_code[e["code"]] = cls
    return by_code


_BY_CODE = _make_classes()
RPC_ERRORS = tuple(_BY_CODE.values())


def from_answer(error: dict, method: str | None = None) -> RpcError:
    """The exception for a JSON-RPC error object {code, message, data}."""
    code = error.get("code", 0)
    data = error.get("data") if isinstance(error.get("data"), dict) else {}
    cls = _BY_CODE.get(code, RpcError)
    return cls(str(error.get("message", "")), code=code, errc=data.get("errc"),
               field=data.get("field"), method=method, data=data)


def by_name(name: str) -> type[RpcError]:
    """The class named in x-error-codes ("Unauthorized")."""
    for cls in RPC_ERRORS:
        if cls.__name__ == name:
            return cls
    raise KeyError(name)


__all__ = ["GonioError", "RpcError", "ConnectionLost", "RequestTimeout", "TlsError", "ScanNotCompleted",
           "from_answer", "by_name", *(c.__name__ for c in RPC_ERRORS)]
