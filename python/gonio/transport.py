"""The links to goniod: NDJSON over a Unix socket or TCP, HTTP POST /rpc, WebSocket /ws.

A transport carries JSON messages and knows nothing of methods or tokens. Every wait has
a deadline (time.monotonic()); a link that breaks raises ConnectionLost, a deadline that
passes RequestTimeout. Notifications that arrive while a call waits for its answer are kept
in `notifications`, in order, for whoever subscribed on this link.

URLs: unix:PATH, unix://PATH (unix:///run/gonio/goniod.sock), tcp://HOST:PORT,
http://HOST:PORT (POST /rpc; subscriptions over ws://HOST:PORT/ws on the same listener),
and the same over TLS: tls://HOST:PORT (NDJSON), https://HOST:PORT (and wss://). TLS
verifies goniod's certificate against `ca` (else the system's CAs) and its name against
HOST, as gonioctl --ca does; a client certificate (cert, key) is offered when given.
"""
from __future__ import annotations

import base64
import collections
import hashlib
import http.client
import json
import os
import select
import socket
import ssl
import struct
import time
import urllib.parse
from dataclasses import dataclass

from .errors import ConnectionLost, RequestTimeout, TlsError

MAX_MESSAGE = 64 << 20  # the most a goniod may send (server.max_message_bytes is at most 64 MiB)


@dataclass(frozen=True)
class Address:
    scheme: str  # "unix", "tcp", "http", "tls", "https"
    path: str = ""  # unix
    host: str = ""
    port: int = 0

    @property
    def secure(self) -> bool:
        return self.scheme in ("tls", "https")

    @property
    def http(self) -> bool:
        return self.scheme in ("http", "https")

    def __str__(self) -> str:
        return f"unix:{self.path}" if self.scheme == "unix" else f"{self.scheme}://{self.host}:{self.port}"


def parse_url(url: str) -> Address:
    """unix:PATH | unix://PATH | tcp://HOST:PORT | http://HOST:PORT[/rpc] | tls://HOST:PORT |
    https://HOST:PORT[/rpc]."""
    if url.startswith("unix:"):
        path = url[len("unix://"):] if url.startswith("unix://") else url[len("unix:"):]
        if not path:
            raise ValueError(f"url {url!r}: no socket path (unix:///run/gonio/goniod.sock)")
        return Address("unix", path=path)
    u = urllib.parse.urlsplit(url)
    if u.scheme not in ("tcp", "http", "tls", "https") or not u.hostname or u.port is None:
        raise ValueError(f"url {url!r}: expected unix:PATH, tcp://HOST:PORT, http://HOST:PORT, "
                         "tls://HOST:PORT or https://HOST:PORT")
    if u.path not in ("", "/", "/rpc"):
        raise ValueError(f"url {url!r}: goniod answers JSON-RPC at /rpc only")
    return Address(u.scheme, host=u.hostname, port=u.port)


def _left(deadline: float) -> float:
    left = deadline - time.monotonic()
    if left <= 0:
        raise RequestTimeout("no answer from goniod in time")
    return left


class StreamLink:
    """Messages over a byte stream: NDJSON lines, or WebSocket text frames (subclass)."""

    def __init__(self, sock: socket.socket, name: str):
        self._sock = sock
        self._buf = bytearray()
        self.name = name
        self.notifications: collections.deque = collections.deque()

    def close(self) -> None:
        try:
            self._sock.close()
        except OSError:
            pass

    def closed_by_peer(self) -> bool:
        """Whether goniod has closed this idle link: what is readable is read into the buffer
        (notifications, a late answer), and end of stream means closed. A request is thus
        never written into a dead connection and counted as sent."""
        try:
            if not select.select([self._sock], [], [], 0)[0]:
                return False
            self._sock.setblocking(False)
            chunk = self._sock.recv(1 << 16)
        except (BlockingIOError, InterruptedError, ssl.SSLWantReadError):
            return False
        except OSError:
            return True
        if not chunk:
            return True
        self._buf += chunk
        return False

    def send(self, message) -> None:
        data = json.dumps(message, separators=(",", ":")).encode()
        try:
            self._sock.settimeout(30)
            self._sock.sendall(self._frame(data))
        except OSError as e:
            raise ConnectionLost(f"{self.name}: sending failed: {e}") from e

    def receive(self, deadline: float):
        """The next message (a parsed JSON value), or RequestTimeout at the deadline."""
        return json.loads(self._read_message(deadline))

    def answer(self, msg_id, deadline: float):
        """The answer with this id; notifications met on the way are kept."""
        while True:
            try:
                m = self.receive(deadline)
            except RequestTimeout:
                raise
            except ConnectionLost as e:
                raise ConnectionLost(str(e), sent=True) from e
            if isinstance(m, dict) and "id" not in m:
                self.notifications.append(m)
            elif isinstance(m, dict) and (m.get("id") == msg_id or m.get("id") is None):
                return m
            # else: a late answer to a call that timed out: dropped

    def _recv_some(self, deadline: float) -> None:
        self._sock.settimeout(_left(deadline))
        try:
            chunk = self._sock.recv(1 << 16)
        except socket.timeout as e:
            raise RequestTimeout(f"{self.name}: no answer from goniod in time") from e
        except OSError as e:
            raise ConnectionLost(f"{self.name}: {e}") from e
        if not chunk:
            raise ConnectionLost(f"{self.name}: goniod closed the connection")
        self._buf += chunk

    def _frame(self, data: bytes) -> bytes:
        return data + b"\n"

    def _read_message(self, deadline: float) -> bytes:
        while True:
            nl = self._buf.find(b"\n")
            if nl >= 0:
                line = bytes(self._buf[:nl])
                del self._buf[:nl + 1]
                return line
            if len(self._buf) > MAX_MESSAGE:
                raise ConnectionLost(f"{self.name}: a line longer than {MAX_MESSAGE} bytes")
            self._recv_some(deadline)


class WebSocketLink(StreamLink):
    """A WebSocket client (RFC 6455): text frames out (masked, §5.3), text frames in; pings
    answered; a Close frame ends the link."""

    def _frame(self, data: bytes) -> bytes:
        n = len(data)
        if n < 126:
            head = struct.pack("!BB", 0x81, 0x80 | n)
        elif n < 1 << 16:
            head = struct.pack("!BBH", 0x81, 0x80 | 126, n)
        else:
            head = struct.pack("!BBQ", 0x81, 0x80 | 127, n)
        mask = os.urandom(4)
        return head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data))

    def _take(self, n: int, deadline: float) -> bytes:
        while len(self._buf) < n:
            self._recv_some(deadline)
        out = bytes(self._buf[:n])
        del self._buf[:n]
        return out

    def _read_message(self, deadline: float) -> bytes:
        message = b""
        while True:
            b0, b1 = self._take(2, deadline)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack("!H", self._take(2, deadline))[0]
            elif n == 127:
                n = struct.unpack("!Q", self._take(8, deadline))[0]
            if n > MAX_MESSAGE:
                raise ConnectionLost(f"{self.name}: a frame of {n} bytes")
            mask = self._take(4, deadline) if b1 & 0x80 else b""
            payload = self._take(n, deadline)
            if mask:
                payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
            op = b0 & 0x0F
            if op == 0x8:
                raise ConnectionLost(f"{self.name}: goniod closed the WebSocket")
            if op == 0x9:  # ping: pong with its payload (§5.5.2)
                self._sock.sendall(struct.pack("!BB", 0x8A, 0x80 | len(payload)) + b"\0\0\0\0" + payload)
                continue
            if op in (0x1, 0x0):
                message += payload
                if b0 & 0x80:
                    return message


def tls_context(ca: str | None, cert: str | None, key: str | None) -> ssl.SSLContext:
    """Verifies the server against `ca` (a PEM bundle; None: the system's CAs) and its name;
    TLS 1.2 at least; offers the client certificate `cert` (and `key`) when given."""
    ctx = ssl.create_default_context(cafile=ca)
    ctx.minimum_version = ssl.TLSVersion.TLSv1_2
    if cert:
        ctx.load_cert_chain(cert, key)
    return ctx


def _connect_socket(a: Address, timeout: float, tls: ssl.SSLContext | None = None) -> socket.socket:
    try:
        if a.scheme == "unix":
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.settimeout(timeout)
            s.connect(a.path)
            return s
        s = socket.create_connection((a.host, a.port), timeout=timeout)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError as e:
        raise ConnectionLost(f"cannot connect to {a}: {e}") from e
    if not a.secure:
        return s
    try:
        return tls.wrap_socket(s, server_hostname=a.host)
    except ssl.SSLCertVerificationError as e:
        s.close()
        raise TlsError(f"{a}: the server's certificate is not trusted: {e.verify_message} "
                       "(ca= names the CA that signed it)") from e
    except (OSError, ssl.SSLError) as e:
        s.close()
        raise ConnectionLost(f"{a}: TLS handshake failed: {e}") from e


def open_stream(a: Address, timeout: float, token: str | None, tls: ssl.SSLContext | None = None) -> StreamLink:
    """A link that carries notifications: NDJSON for unix/tcp/tls, a WebSocket for http(s)."""
    s = _connect_socket(a, timeout, tls)
    if not a.http:
        return StreamLink(s, str(a))
    key = base64.b64encode(os.urandom(16)).decode()
    req = (f"GET /ws HTTP/1.1\r\nHost: {a.host}:{a.port}\r\nUpgrade: websocket\r\n"
           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n")
    if token:
        req += f"Authorization: Bearer {token}\r\n"
    link = WebSocketLink(s, f"{'wss' if a.secure else 'ws'}://{a.host}:{a.port}/ws")
    try:
        s.sendall((req + "\r\n").encode())
        deadline = time.monotonic() + timeout
        while b"\r\n\r\n" not in link._buf:
            link._recv_some(deadline)
    except (OSError, RequestTimeout) as e:
        link.close()
        raise ConnectionLost(f"{link.name}: handshake failed: {e}") from e
    head, _, rest = bytes(link._buf).partition(b"\r\n\r\n")
    link._buf = bytearray(rest)
    status_line, *headers = head.decode("latin-1").split("\r\n")
    if status_line.split(" ")[1:2] != ["101"]:
        link.close()
        _raise_http_refusal(status_line, rest)
    # §4.2.2: the server proves it read our key.
    accept = base64.b64encode(hashlib.sha1((key + "258EAFA5-E914-47DA-95CA-C5AB0DC85B11").encode()).digest())
    if not any(h.lower().startswith("sec-websocket-accept:") and h.split(":", 1)[1].strip() == accept.decode()
               for h in headers):
        link.close()
        raise ConnectionLost(f"{link.name}: the server's Sec-WebSocket-Accept does not match")
    return link


def _raise_http_refusal(status_line: str, body: bytes):
    from .errors import from_answer
    try:
        answer = json.loads(body)
    except ValueError:
        raise ConnectionLost(f"WebSocket refused: {status_line}") from None
    if isinstance(answer, dict) and "error" in answer:
        raise from_answer(answer["error"])
    raise ConnectionLost(f"WebSocket refused: {status_line}")


class HttpLink:
    """JSON-RPC over HTTP POST /rpc on one keep-alive connection, bearer token in a header."""

    def __init__(self, a: Address, timeout: float, token: str | None, tls: ssl.SSLContext | None = None):
        self.name = f"{a.scheme}://{a.host}:{a.port}/rpc"
        self._conn = (http.client.HTTPSConnection(a.host, a.port, timeout=timeout, context=tls) if a.secure
                      else http.client.HTTPConnection(a.host, a.port, timeout=timeout))
        self._token = token
        self.notifications: collections.deque = collections.deque()  # HTTP has none
        try:
            self._conn.connect()
            self._conn.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except ssl.SSLCertVerificationError as e:
            raise TlsError(f"{self.name}: the server's certificate is not trusted: {e.verify_message} "
                           "(ca= names the CA that signed it)") from e
        except OSError as e:
            raise ConnectionLost(f"cannot connect to {self.name}: {e}") from e

    def close(self) -> None:
        self._conn.close()

    def closed_by_peer(self) -> bool:
        """An idle keep-alive connection with something to read has been closed (or sent
        what no request asked for): either way it is not reused."""
        sock = self._conn.sock
        try:
            if sock is None or not select.select([sock], [], [], 0)[0]:
                return False
        except OSError:
            pass
        self._conn.close()
        return True

    def exchange(self, message, deadline: float):
        body = json.dumps(message, separators=(",", ":")).encode()
        headers = {"Content-Type": "application/json"}
        if self._token:
            headers["Authorization"] = f"Bearer {self._token}"
        sent = False
        try:
            self._conn.timeout = _left(deadline)
            if self._conn.sock is not None:
                self._conn.sock.settimeout(self._conn.timeout)
            self._conn.request("POST", "/rpc", body, headers)
            sent = True
            resp = self._conn.getresponse()
            data = resp.read()
        except socket.timeout as e:
            self._conn.close()
            raise RequestTimeout(f"{self.name}: no answer from goniod in time") from e
        except (OSError, http.client.HTTPException) as e:
            self._conn.close()
            raise ConnectionLost(f"{self.name}: {e}", sent=sent) from e
        if resp.status == 204 or not data:
            return None
        try:
            return json.loads(data)
        except ValueError as e:
            raise ConnectionLost(f"{self.name}: HTTP {resp.status} without a JSON answer", sent=True) from e
