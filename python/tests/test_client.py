"""The client against a real goniod on the mock: the three transports, tokens, errors that
name their field, results as frames, subscriptions, reconnection and the command line."""
import asyncio
import os
import subprocess
import sys
import threading
import time

import pytest

import gonio
from goniod_process import TRUE_SAMPLE

GRID = "in=45;out=-30:30:10"  # 7 geometries


@pytest.fixture(scope="module")
def admin(goniod):
    with gonio.connect(goniod.url("unix"), state_dir=goniod.state_dir) as c:
        c.sample.create(name="white", bsdf=TRUE_SAMPLE, tolerance=0.05)
        yield c


def test_unix_socket_gives_the_role_of_the_uid(goniod, admin):
    assert admin.principal["role"] == "admin"
    assert admin.principal["transport"] == "unix"
    assert "version" in admin.system.info()


@pytest.mark.parametrize("scheme", ["tcp", "http"])
def test_tcp_and_http_log_in_with_a_token(goniod, admin, scheme):
    with gonio.connect(goniod.url(scheme), token_file=goniod.token_file) as c:
        assert c.principal["role"] == "admin"
        assert c.sample.get(sample="white")["name"] == "white"
        assert c.rpc.discover()["info"]["title"] == "goniod"
    # the state dir's admin.token, as gonioctl finds it
    with gonio.connect(goniod.url(scheme), state_dir=goniod.state_dir) as c:
        assert c.auth.whoami()["role"] == "admin"


@pytest.mark.parametrize("scheme", ["tcp", "http"])
def test_a_wrong_token_is_unauthorized(goniod, scheme):
    with pytest.raises(gonio.Unauthorized) as e:
        gonio.connect(goniod.url(scheme), token="not-a-token")
    assert e.value.code == -32000 and e.value.errc == "unauthorized"


def test_tcp_without_a_token_says_how_to_give_one(goniod, tmp_path):
    with pytest.raises(gonio.Unauthorized, match="token_file"):
        gonio.connect(goniod.url("tcp"), state_dir=str(tmp_path))


def test_a_revoked_token_is_refused_on_its_open_connection_and_after(goniod, admin):
    token = admin.auth.create_token(name="lab-notebook", role="technician")["token"]
    tcp = gonio.connect(goniod.url("tcp"), token=token, reconnect=2)
    web = gonio.connect(goniod.url("http"), token=token)
    assert tcp.principal["role"] == web.principal["role"] == "technician"
    with pytest.raises(gonio.Forbidden):
        tcp.auth.list_tokens()  # admin only
    admin.auth.revoke_token(name="lab-notebook")
    with pytest.raises(gonio.Unauthorized):
        tcp.system.info()
    with pytest.raises(gonio.Unauthorized):
        web.system.info()
    tcp.close(), web.close()


@pytest.mark.parametrize("call, field, cls", [
    (lambda c: c.sample.create(name="grey", tolerance=5), "tolerance", "InvalidParams"),
    (lambda c: c.scan.submit(sample="white", grids="in=95;out=0"), "grids", "InvalidParams"),
    (lambda c: c.scan.submit(sample="white", grids=GRID, wavelengths="100:700:10"), "wavelengths", None),
    (lambda c: c.scan.submit(sample="white", geometries=["45/-45"]), "geometries[0]", "PlanRejected"),
    (lambda c: c.scan.get(scan=999), "scan", "NotFound"),
    (lambda c: c.scan.submit(sample="white", grid=GRID), "grid", "InvalidParams"),
])
def test_bad_parameters_raise_their_class_naming_the_field(admin, call, field, cls):
    with pytest.raises(gonio.RpcError) as e:
        call(admin)
    assert e.value.field is not None and e.value.field.startswith(field), (e.value.field, str(e.value))
    if cls:
        assert type(e.value).__name__ == cls, str(e.value)
    assert e.value.errc and e.value.code < 0


def submit(client, **plan):
    return client.scan.submit(**{"sample": "white", "grids": GRID, "wavelengths": "400:700:50", **plan})["id"]


@pytest.mark.parametrize("scheme", ["unix", "tcp", "http"])
def test_submit_wait_and_a_frame_on_every_transport(goniod, admin, scheme):
    with gonio.connect(goniod.url(scheme), state_dir=goniod.state_dir) as c:
        scan = submit(c)
        done = c.scan.wait(scan=scan, timeout=120, progress=False)
        assert done["state"] == "completed" and done["points_done"] == 7
        pts = c.scan.points(scan=scan, page=3)  # three pages
        assert [p["index"] for p in pts] == list(range(7))
        f = pts.to_frame()
        assert len(f) == 7 * 7
        assert f["predicted"].notna().all() and (f["measured_u"] > 0).all()
        assert set(f["decision"]) <= {"agrees", "out_of_tolerance", "undecided"}
        assert any(col.startswith("budget:") for col in f.columns)
        # the mock's sample is the catalog's: measured within a few u of predicted
        z = (f["measured"] - f["predicted"]).abs() / (f["measured_u"] ** 2 + f["predicted_se"] ** 2) ** 0.5
        assert z.median() < 3


def test_exports_and_fits_are_objects(goniod, admin, tmp_path):
    scan = submit(admin, grids="in=45;out=-30:60:5")
    admin.scan.wait(scan=scan, progress=False)
    ex = admin.scan.export(scan=scan, format="csv", limit=4)  # five chunks, one file
    frame = ex.to_frame()
    assert len(frame) == 19 * 7 and "predicted_se" in frame.columns
    assert ex.content.count("\n") == 19 * 7 + 2  # a comment line, the header, the rows
    path = ex.save(tmp_path / "scan.csv")
    assert open(path).read() == ex.content
    fit = admin.scan.fit(scan=scan, model="lambert:albedo=?", samples=2048)
    (albedo,) = fit.parameters
    assert abs(albedo["value"] - 0.6) < 4 * albedo["u"] + 0.01, fit
    assert fit.to_frame().loc[0, "name"] == albedo["name"]


def test_a_scan_that_is_cancelled_raises_scan_not_completed(admin):
    scan = submit(admin, grids="in=45;out=-30:80:1", not_before="2099-01-01T00:00:00Z")
    threading.Timer(0.5, lambda: admin.scan.cancel(scan=scan, reason="test")).start()
    with pytest.raises(gonio.ScanNotCompleted) as e:
        admin.scan.wait(scan=scan, timeout=30, progress=False)
    assert e.value.scan["state"] == "cancelled"
    assert admin.scan.wait(scan=scan, check=False)["state"] == "cancelled"


@pytest.mark.parametrize("scheme", ["unix", "http"])
def test_subscriptions_iterate(goniod, admin, scheme):
    with gonio.connect(goniod.url(scheme), state_dir=goniod.state_dir) as c:
        with c.subscribe("scan.point", "scan.progress") as sub:
            scan = submit(c)
            points, progress = [], []
            while len(points) < 7:
                note = sub.next(timeout=60)
                assert note is not None, "no notification within 60 s"
                if note.params.get("scan_id", note.params.get("scan")) != scan:
                    continue
                (points if note.method == "scan.point" else progress).append(note.params)
            assert [p["index"] for p in points] == list(range(7))
            assert progress and progress[-1]["points_total"] == 7


def test_subscriptions_are_async_iterators(goniod, admin):
    async def main():
        c = gonio.connect(goniod.url("tcp"), state_dir=goniod.state_dir)
        async with c.subscribe("progress") as sub:
            scan = await asyncio.to_thread(submit, c)
            async for note in sub:
                if note.params["scan"] == scan and note.params["state"] == "completed":
                    return note.params
    final = asyncio.run(asyncio.wait_for(main(), 60))
    assert final["points_done"] == 7


def test_a_thousand_points_of_31_channels_paged_into_a_frame(goniod, admin):
    scan = admin.scan.submit(sample="white", grids="in=45;out=-30:69:1", repeats=10,
                             wavelengths="400:700:10", reference="start")["id"]
    admin.scan.wait(scan=scan, progress=False, timeout=300)
    pts = admin.scan.points(scan=scan)
    assert len(pts) == 1000 and pts.points_total == 1000
    # a page too large for goniod's answer limit (8 MiB) is halved until it fits
    assert [p["index"] for p in admin.scan.points(scan=scan, offset=100, page=1000)] == list(range(100, 1000))
    f = pts.to_frame()
    assert f.shape[0] == 31000
    assert f["wavelength_nm"].nunique() == 31 and f["index"].nunique() == 1000
    assert f.groupby("geometry_index").size().eq(310).all()


@pytest.mark.parametrize("scheme", ["unix", "tcp", "http"])
def test_the_client_reconnects_across_a_goniod_restart(own_goniod, scheme):
    d = own_goniod
    c = gonio.connect(d.url(scheme), state_dir=d.state_dir, reconnect=30)
    c.sample.create(name="before", bsdf=None)
    d.stop()
    d.start()
    # a write after the restart is sent once on the new link (the dead one is noticed first)
    assert c.sample.create(name="after", bsdf=None)["name"] == "after"
    assert c.reconnects == 1
    # a call while goniod is down waits for it, with back-off
    d.stop()
    started, failed = threading.Event(), []

    def start_later():
        started.set()  # before goniod is up: the call cannot have been answered earlier
        try:
            d.start()
        except Exception as e:  # noqa: BLE001 — reported by the test below
            failed.append(e)
    timer = threading.Timer(1.0, start_later)
    timer.start()
    try:
        names = {s["name"] for s in c.sample.list()}
    finally:
        timer.join()
        assert not failed, f"goniod did not start again: {failed}"
    assert names >= {"before", "after"}
    assert started.is_set() and c.reconnects == 2
    c.close()


def test_a_call_gives_up_after_the_reconnect_time(own_goniod):
    c = gonio.connect(own_goniod.url("tcp"), state_dir=own_goniod.state_dir, reconnect=1)
    own_goniod.stop()
    with pytest.raises(gonio.ConnectionLost):
        c.system.info()


def run_cli(d, *args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.run([sys.executable, "-m", "gonio", "--connect", d.url("tcp"),
                           "--token-file", d.token_file, *args],
                          capture_output=True, text=True, env=env, timeout=120)


def test_the_command_line(goniod, admin, tmp_path):
    r = run_cli(goniod, "status")
    assert r.returncode == 0 and "instrument" in r.stdout, r.stderr
    r = run_cli(goniod, "submit", "--sample", "white", "--grid", GRID, "--wavelengths", "400:700:100", "--wait")
    assert r.returncode == 0, r.stderr
    scan = int(r.stdout.split()[0])
    out = tmp_path / "s.csv"
    r = run_cli(goniod, "export", str(scan), "--output", str(out))
    assert r.returncode == 0 and "\nindex,geometry_index," in out.read_text(), r.stderr
    r = run_cli(goniod, "submit", "--sample", "white", "--grid", "in=95;out=0")
    assert r.returncode == 2 and "field grids" in r.stderr, r.stderr
    r = run_cli(goniod, "wait", "999")
    assert r.returncode == 5, r.stderr
    r = subprocess.run([sys.executable, "-m", "gonio", "--help"], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert r.returncode == 0 and "status" in r.stdout and "export" in r.stdout


def test_the_fifteen_line_example_script(goniod, admin, tmp_path):
    admin.sample.create(name="paint", bsdf="lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", tolerance=0.02)
    script = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "submit_wait_plot.py")
    with open(script) as f:
        assert len(f.read().splitlines()) <= 15
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), GONIO_STATE_DIR=goniod.state_dir,
               MPLBACKEND="Agg", MPLCONFIGDIR=str(tmp_path))
    r = subprocess.run([sys.executable, script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "scan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("scheme", ["tcp", "http"])
def test_a_subscription_subscribes_again_after_a_restart(own_goniod, scheme):
    d = own_goniod
    c = gonio.connect(d.url(scheme), state_dir=d.state_dir)
    c.sample.create(name="white", bsdf=TRUE_SAMPLE)
    with c.subscribe("scan.progress") as sub:
        d.stop()
        d.start()
        assert sub.next(timeout=0.5) is None  # notices the drop, opens a new link, subscribes
        scan = submit(c)
        note = sub.next(timeout=60)
        assert note is not None and note.params["scan"] == scan
        assert sub.reconnects == 1
