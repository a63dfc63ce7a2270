"""The client: a connection to goniod and every method of openrpc.json as a Python method.

    with gonio.connect("tcp://127.0.0.1:7700", token_file="admin.token") as client:
        scan = client.scan.submit(sample="paint", grids="in=45;out=-30:80:2")

Method `area.verb` of the document is `client.area.verb(**params)`, keyword arguments by
the schema's names, its docstring made from the schema's summary, description and
parameters. A few return richer objects than the JSON result (scan.points, scan.export,
scan.fit: results.py); `client.scan.wait` and `client.subscribe` are the client's own
(waiting.py, subscription.py). `client.call(method, **params)` calls anything by name.

Connections: a Unix socket gets its role from the peer's uid (no token, as gonioctl);
TCP logs in with auth.login; HTTP sends the token as a bearer header. A link that drops is
opened again, with back-off (0.1 s doubling to 5 s) for up to `reconnect` seconds, and
logged in again; a call is sent again only when it had not reached goniod or reads only
(a method a viewer may call), so nothing is submitted twice.
"""
from __future__ import annotations

import inspect
import os
import threading
import time

from . import errors, schema, transport
from .errors import ConnectionLost


class _Omitted:
    """The default of an optional parameter: not sent, so goniod's default applies."""

    def __repr__(self) -> str:
        return "<goniod's default>"

    def __bool__(self) -> bool:
        return False


OMIT = _Omitted()
TERMINAL_STATES = ("completed", "failed", "cancelled")
CLIENT_ONLY = ("scan.wait",)  # the client's own helpers, not JSON-RPC methods


def default_state_dir() -> str:
    """$GONIO_STATE_DIR or /var/lib/gonio: where goniod keeps its socket and admin.token."""
    return os.environ.get("GONIO_STATE_DIR") or "/var/lib/gonio"


def _unauthorized(message: str) -> errors.RpcError:
    return errors.by_name("Unauthorized")(message, errc="unauthorized")


def _invalid(method: str, field: str, message: str) -> errors.RpcError:
    return errors.by_name("InvalidParams")(f"{field}: {message}", errc="invalid_argument",
                                           field=field, method=method)


def checked_params(spec: schema.Method, params: dict) -> dict:
    """The params to send: omitted ones dropped; unknown and missing names refused here,
    naming the field (values are goniod's to check: it names the field and the range)."""
    known = {p.name for p in spec.params}
    for k in params:
        if k not in known:
            raise _invalid(spec.name, k, f"{spec.name} has no parameter '{k}' "
                                          f"(parameters: {', '.join(sorted(known)) or 'none'})")
    out = {k: v for k, v in params.items() if v is not OMIT}
    for p in spec.params:
        if p.required and p.name not in out:
            raise _invalid(spec.name, p.name, f"{spec.name} needs '{p.name}' ({p.description})")
    return out


class Client:
    """A connection to goniod. url: unix:PATH, unix://PATH, tcp://HOST:PORT,
    http://HOST:PORT, tls://HOST:PORT or https://HOST:PORT (default: the state dir's
    socket). token / token_file: the bearer token for TCP, TLS and HTTP (default:
    <state_dir>/admin.token when readable). ca: the CA file that goniod's certificate is
    verified by (tls://, https://; default: the system's CAs); cert, key: a client
    certificate, whose CN names a token on goniod, instead of the token. timeout: seconds
    per call; reconnect: seconds to keep trying when the link drops (0: never)."""

    def __init__(self, url: str | None = None, *, token: str | None = None,
                 token_file: str | os.PathLike | None = None, state_dir: str | None = None,
                 timeout: float = 30.0, reconnect: float = 30.0, ca: str | None = None,
                 cert: str | None = None, key: str | None = None):
        self.state_dir = str(state_dir or default_state_dir())
        self.url = url or f"unix:{self.state_dir}/goniod.sock"
        self.address = transport.parse_url(self.url)
        self.timeout = float(timeout)
        self.reconnect = float(reconnect)
        self._tls = transport.tls_context(ca, cert, key) if self.address.secure else None
        self._certified = bool(cert) and self.address.secure
        self._token, self._explicit_token = self._find_token(token, token_file)
        self._link = None
        self._next_id = 1
        self._lock = threading.RLock()
        self.principal: dict | None = None  # whom goniod takes this client for
        self.reconnects = 0  # links opened again after a drop or a close
        self._opened = 0
        for name, cls in _AREAS.items():
            setattr(self, name, cls(self))
        with self._lock:
            self._ensure_link()

    # ---- connection -------------------------------------------------------------------------

    def _find_token(self, token, token_file) -> tuple[str | None, bool]:
        if token:
            return str(token).strip(), True
        if token_file:
            with open(token_file, encoding="utf-8") as f:
                return f.readline().strip(), True
        if self.address.scheme == "unix":
            return None, False
        try:
            with open(os.path.join(self.state_dir, "admin.token"), encoding="utf-8") as f:
                return f.readline().strip() or None, False
        except OSError:
            return None, False

    def _open_link(self):
        """A new link, logged in; sets principal."""
        a = self.address
        if a.scheme != "unix" and not self._token and not self._certified:
            raise _unauthorized(f"a token is needed over {a.scheme}: token=, token_file= or a "
                                f"readable {self.state_dir}/admin.token")
        if a.http:
            link = transport.HttpLink(a, self.timeout, self._token, self._tls)
            try:
                self.principal = self._exchange(link, "auth.whoami", {}, time.monotonic() + self.timeout)
            except Exception:
                link.close()
                raise
            return link
        link = transport.open_stream(a, self.timeout, None, self._tls)
        self._log_in(link)
        return link

    def _log_in(self, link) -> None:
        """auth.login on a new NDJSON link: always over TCP and TLS (unless a client
        certificate stands for the token), over the Unix socket only with a given token."""
        if not self._token or (self.address.scheme == "unix" and not self._explicit_token):
            return
        try:
            self.principal = self._exchange(link, "auth.login", {"token": self._token},
                                            time.monotonic() + self.timeout)
        except Exception:
            link.close()
            raise

    def _ensure_link(self):
        if self._link is not None and not self._link.closed_by_peer():
            return self._link
        reopening = self._link is not None or self._opened > 0
        self._drop()
        try:
            self._link = self._open_link()
        except ConnectionLost as e:  # the call itself was not sent
            raise ConnectionLost(str(e), sent=False) from e
        self._opened += 1
        self.reconnects += reopening
        if self.principal is None:
            self.principal = self._exchange(self._link, "auth.whoami", {}, time.monotonic() + self.timeout)
        return self._link

    def _drop(self) -> None:
        if self._link is not None:
            self._link.close()
            self._link = None

    def close(self) -> None:
        """Closes the link (a later call opens it again)."""
        with self._lock:
            self._drop()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        who = self.principal or {}
        return f"<gonio.Client {self.url} as {who.get('name', '?')} ({who.get('role', '?')})>"

    # ---- calls ------------------------------------------------------------------------------

    def _exchange(self, link, method: str, params: dict, deadline: float):
        msg_id = self._next_id
        self._next_id += 1
        request = {"jsonrpc": "2.0", "id": msg_id, "method": method, "params": params}
        if isinstance(link, transport.HttpLink):
            answer = link.exchange(request, deadline)
        else:
            link.send(request)
            answer = link.answer(msg_id, deadline)
        if not isinstance(answer, dict):
            raise ConnectionLost(f"{method}: goniod's answer is not a JSON-RPC response", sent=True)
        if "error" in answer:
            raise errors.from_answer(answer["error"], method)
        return answer.get("result")

    def call(self, method: str, _timeout: float | None = None, **params):
        """Calls a JSON-RPC method by name with params by name; returns its result."""
        spec = schema.methods().get(method)
        return self._call(method, params, _timeout, spec.read_only if spec else False)

    def _call(self, method: str, params: dict, timeout: float | None, read_only: bool):
        timeout = self.timeout if timeout is None else float(timeout)
        delay, first_failure = 0.1, None
        with self._lock:
            while True:
                try:
                    link = self._ensure_link()
                    return self._exchange(link, method, params, time.monotonic() + timeout)
                except ConnectionLost as e:
                    self._drop()
                    if e.sent and not read_only:
                        raise ConnectionLost(f"{method}: the link to goniod dropped after the request "
                                             f"was sent; it may or may not have been done ({e})",
                                             sent=True) from e
                    now = time.monotonic()
                    first_failure = first_failure or now
                    if now + delay - first_failure > self.reconnect:
                        raise
                    time.sleep(delay)
                    delay = min(2 * delay, 5.0)

    def subscribe(self, *names: str, topics=OMIT, scan=OMIT):
        """Notifications on a link of their own, as an iterator and an async iterator.

        names: notification methods ("scan.progress", "scan.point", "alert",
        "instrument.state", "scan.state") or topics ("progress", "points", "alerts",
        "state"); topics: the same as a list (the JSON-RPC parameter); none: all. scan: only
        progress and points of this scan. See subscription.Subscription."""
        from .subscription import Subscription
        names = list(names) + (list(topics) if topics is not OMIT else [])
        return Subscription(self, names, None if scan is OMIT else scan)

    def _open_stream(self):
        """A fresh link for notifications (over http: a WebSocket), logged in."""
        a = self.address
        link = transport.open_stream(a, self.timeout, self._token if a.http else None, self._tls)
        if not a.http:
            self._log_in(link)
        return link


def connect(url: str | None = None, **kwargs) -> Client:
    """gonio.connect("tcp://host:7700", token_file=...) — see Client."""
    return Client(url, **kwargs)


# ---- the generated methods ----------------------------------------------------------------

class Area:
    """The methods of one area of the API (client.scan, client.sample, ...)."""

    def __init__(self, client: Client):
        self._client = client

    def __repr__(self) -> str:
        return f"<gonio area {self._area}: {', '.join(self._verbs)}>"


def _signature(spec: schema.Method, extra=()) -> inspect.Signature:
    kw = inspect.Parameter.KEYWORD_ONLY
    ps = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    ps += [inspect.Parameter(p.name, kw) if p.required else inspect.Parameter(p.name, kw, default=OMIT)
           for p in spec.params]
    ps += list(extra)
    ps.append(inspect.Parameter("_timeout", kw, default=None))
    return inspect.Signature(ps)


def _generated(spec: schema.Method):
    def method(self, *, _timeout=None, **params):
        return self._client._call(spec.name, checked_params(spec, params), _timeout, spec.read_only)
    method.__signature__ = _signature(spec)
    method.__doc__ = spec.docstring()
    return method


def _override(spec: schema.Method, fn):
    """A method whose result is made richer by `fn(client, spec, **params)`; its docstring
    is the schema's and fn's own; its signature the schema's params and fn's extras."""
    extras = [p for p in inspect.signature(fn).parameters.values()
              if p.kind == inspect.Parameter.KEYWORD_ONLY and p.name not in {q.name for q in spec.params}
              and p.name != "_timeout"]

    def method(self, **params):
        return fn(self._client, spec, **params)
    method.__signature__ = _signature(spec, extras)
    method.__doc__ = spec.docstring() + "\n\n" + inspect.cleandoc(fn.__doc__ or "")
    return method


def _build_areas() -> dict[str, type]:
    from . import results, waiting
    overrides = {"scan.points": results.points, "scan.export": results.export, "scan.fit": results.fit,
                 "auth.login": _login}
    members: dict[str, dict] = {}
    for spec in schema.methods().values():
        fn = _override(spec, overrides[spec.name]) if spec.name in overrides else _generated(spec)
        fn.__name__ = spec.verb
        if not spec.area:
            if not hasattr(Client, spec.verb):  # subscribe: Client.subscribe's own
                fn.__qualname__ = f"Client.{spec.verb}"
                setattr(Client, spec.verb, _unwrap_area(fn))
            continue
        area = spec.area.replace(".", "_")
        fn.__qualname__ = f"{area}.{spec.verb}"
        members.setdefault(area, {})[spec.verb] = fn
    members["scan"]["wait"] = waiting.wait_method()
    return {area: type(f"{area.title()}Area", (Area,), {**m, "_area": area, "_verbs": tuple(m),
                                                         "__doc__": f"client.{area}: the {area}.* methods."})
            for area, m in members.items()}


def _unwrap_area(fn):
    """A generated method called on the client itself (methods without an area)."""
    def method(self, **params):
        return fn(Area(self), **params)
    method.__signature__ = fn.__signature__
    method.__doc__, method.__name__, method.__qualname__ = fn.__doc__, fn.__name__, fn.__qualname__
    return method


def _login(client: Client, spec: schema.Method, *, token, _timeout=None):
    """Logs this client in with `token` from now on (also after a reconnect); returns the
    principal."""
    with client._lock:
        client._token, client._explicit_token = str(token), True
        client._drop()
        client.principal = None
        client._ensure_link()
        return client.principal


_AREAS = _build_areas()
