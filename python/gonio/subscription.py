"""Subscriptions: goniod's notifications as an iterator and as an asyncio async iterator.

    with client.subscribe("scan.progress", scan=7) as sub:
        for note in sub:                     # blocks; sub.next(timeout=1) polls
            print(note.params["points_done"])

    async for note in client.subscribe("alert"):
        ...

A subscription has a link of its own (NDJSON; a WebSocket over http://), so the client's
calls never wait behind notifications. When the link drops, it is opened again with
back-off (as the client's) and subscribed again; notifications sent meanwhile are lost
(`reconnects` counts the gaps: re-read the state with a call after one).
"""
from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass

from . import schema
from .errors import ConnectionLost, GonioError, RequestTimeout


@dataclass(frozen=True)
class Notification:
    method: str  # "scan.progress", "scan.point", "alert", "instrument.state", "scan.state"
    params: dict


class Subscription:
    def __init__(self, client, names, scan: int | None):
        table = schema.notifications()
        self.methods, topics = set(), []
        for n in names:
            if n in table:
                self.methods.add(n)
                topic = table[n]
            elif n in table.values():
                self.methods |= {m for m, t in table.items() if t == n}
                topic = n
            else:
                raise ValueError(f"subscribe: '{n}' is neither a notification ({', '.join(table)}) "
                                 f"nor a topic ({', '.join(sorted(set(table.values())))})")
            if topic not in topics:
                topics.append(topic)
        self.methods = self.methods or set(table)
        self._params = {"topics": topics} if topics else {}
        if scan is not None:
            self._params["scan"] = scan
        self._client = client
        self._link = None
        self.reconnects = 0
        self._open()

    def _open(self) -> None:
        link = self._client._open_stream()
        try:
            self._client._exchange(link, "subscribe", self._params, time.monotonic() + self._client.timeout)
        except Exception:
            link.close()
            raise
        self._link = link

    def _reopen(self) -> None:
        delay, start = 0.1, time.monotonic()
        while True:
            try:
                self._open()
                self.reconnects += 1
                return
            except ConnectionLost:
                if time.monotonic() + delay - start > self._client.reconnect:
                    raise
                time.sleep(delay)
                delay = min(2 * delay, 5.0)

    def next(self, timeout: float | None = None) -> Notification | None:
        """The next notification; None when `timeout` seconds pass first (None: wait)."""
        if self._link is None:
            raise GonioError("the subscription is closed")
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            link = self._link
            if link.notifications:
                m = link.notifications.popleft()
            else:
                step = 3600.0 if deadline is None else deadline - time.monotonic()
                if step <= 0:
                    return None
                try:
                    m = link.receive(time.monotonic() + step)
                except RequestTimeout:
                    continue
                except ConnectionLost:
                    link.close()
                    self._reopen()
                    continue
            if isinstance(m, dict) and "id" not in m and m.get("method") in self.methods:
                return Notification(m["method"], m.get("params") or {})

    def __iter__(self):
        return self

    def __next__(self) -> Notification:
        return self.next()

    def __aiter__(self):
        return self

    async def __anext__(self) -> Notification:
        # The blocking read in a worker thread, in short steps so that a cancelled task
        # leaves no read behind for long.
        while True:
            note = await asyncio.to_thread(self.next, 0.25)
            if note is not None:
                return note

    def close(self) -> None:
        if self._link is not None:
            self._link.close()
            self._link = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    async def __aenter__(self):
        return self

    async def __aexit__(self, *exc) -> None:
        self.close()
