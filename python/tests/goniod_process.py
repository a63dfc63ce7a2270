"""A real goniod on the mock instrument in a temporary state dir, for the client's tests and
the example notebook: `GONIO_BIN_DIR` names the directory holding goniod (ctest sets it).

The configuration is the integration tests' quick one (tests/support/.../daemon_harness.hpp):
motion without delays (time_scale 0), a twin of one thread at 1 % standard error, so a
scan of a few hundred points takes seconds.
"""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import socket
import subprocess
import tempfile
import time

TRUE_SAMPLE = "lambert:albedo=0.6"  # the mock lab's hidden sample


def free_port() -> int:
    """A free port below Linux's ephemeral range (32768 and up), so that no socket bound to
    port 0 elsewhere takes it while goniod restarts on it."""
    rng = random.Random()
    while True:
        port = rng.randrange(20000, 32768)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
                return port
            except OSError:
                continue


def bin_dir() -> str:
    d = os.environ.get("GONIO_BIN_DIR")
    if not d or not os.path.exists(os.path.join(d, "goniod")):
        raise RuntimeError("GONIO_BIN_DIR must name the directory that holds goniod "
                           "(e.g. GONIO_BIN_DIR=build/ci/bin)")
    return d


def config(tcp_port: int = 0, http_port: int = 0, extra: str = "", listen_more=()) -> str:
    more = "".join(f', "{u}"' for u in listen_more)
    return (f'[server]\nlog_level = "info"\nlisten = ["tcp://127.0.0.1:{tcp_port}", '
            f'"http://127.0.0.1:{http_port}"{more}]\nweb_root = ""\n\n'
            f'[instrument.motion]\ndriver = "mock"\nsample = "{TRUE_SAMPLE}"\ntime_scale = 0\n\n'
            f'[instrument.photometer]\ndriver = "mock"\n\n'
            f'[twin]\nthreads = 1\nrel_se = 0.01\nreplicates = 8\n\n{extra}')


class Goniod:
    """goniod --state-dir TMP --config TMP/test.toml; stop() and start() again on the same
    state dir (ports fixed at construction so that a restart keeps its URLs)."""

    def __init__(self, fixed_ports: bool = True, extra: str = "", listen_more=()):
        self.state_dir = tempfile.mkdtemp(prefix="gonio-pytest-")
        ports = (free_port(), free_port()) if fixed_ports else (0, 0)
        with open(os.path.join(self.state_dir, "test.toml"), "w") as f:
            f.write(config(*ports, extra, listen_more))
        self.proc = None
        self.start()

    def start(self) -> None:
        endpoints = os.path.join(self.state_dir, "endpoints.json")
        if os.path.exists(endpoints):
            os.remove(endpoints)
        log = open(os.path.join(self.state_dir, "goniod.log"), "ab")
        self.proc = subprocess.Popen([os.path.join(bin_dir(), "goniod"), "--state-dir", self.state_dir,
                                      "--config", os.path.join(self.state_dir, "test.toml")],
                                     stdout=log, stderr=subprocess.STDOUT)
        log.close()
        end = time.monotonic() + 30
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                raise RuntimeError(f"goniod exited at start-up ({self.proc.returncode}): {self.log()}")
            if os.path.exists(endpoints) and self._answers():
                with open(endpoints) as f:
                    self.endpoints = json.load(f)["listen"]
                return
            time.sleep(0.05)
        raise RuntimeError(f"goniod did not come up: {self.log()}")

    def _answers(self) -> bool:
        try:
            with socket.socket(socket.AF_UNIX) as s:
                s.settimeout(5)
                s.connect(self.socket_path)
                s.sendall(b'{"jsonrpc":"2.0","id":1,"method":"system.info"}\n')
                return b'"result"' in s.recv(1 << 16)
        except OSError:
            return False

    def stop(self, sig: int = signal.SIGTERM) -> int:
        if self.proc is None:
            return 0
        self.proc.send_signal(sig)
        try:
            rc = self.proc.wait(30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            rc = self.proc.wait()
        self.proc = None
        return rc

    def close(self) -> None:
        self.stop(signal.SIGKILL)
        shutil.rmtree(self.state_dir, ignore_errors=True)

    @property
    def socket_path(self) -> str:
        return os.path.join(self.state_dir, "goniod.sock")

    @property
    def token_file(self) -> str:
        return os.path.join(self.state_dir, "admin.token")

    def url(self, scheme: str) -> str:
        if scheme == "unix":
            return "unix://" + self.socket_path
        return next(u for u in self.endpoints if u.startswith(scheme + "://"))

    def log(self) -> str:
        try:
            with open(os.path.join(self.state_dir, "goniod.log"), errors="replace") as f:
                return f.read()[-4000:]
        except OSError:
            return ""
