"""The client against the API document, without a server: every method of
proto/openrpc.json is a method of the client with the schema's parameters and description,
every error code an exception class, and the package carries the same document."""
import inspect
import json
import os

import pytest

import gonio
from gonio import client as client_module

SOURCE = os.path.join(os.path.dirname(__file__), "..", "..", "proto", "openrpc.json")


def source_document():
    with open(SOURCE, encoding="utf-8") as f:
        return json.load(f)


def member(method: str):
    """client.<area>.<verb> as the Client class holds it (no connection needed)."""
    area, _, verb = method.rpartition(".")
    if not area:
        return getattr(gonio.Client, verb)
    return getattr(client_module._AREAS[area.replace(".", "_")], verb)


def test_the_package_carries_the_repository_document():
    assert gonio.document() == source_document()


@pytest.mark.parametrize("method", [m["name"] for m in source_document()["methods"]])
def test_every_method_is_in_the_client(method):
    spec = next(m for m in source_document()["methods"] if m["name"] == method)
    fn = member(method)
    assert callable(fn), method
    params = inspect.signature(fn).parameters
    for p in spec.get("params", []):
        assert p["name"] in params, f"{method}: parameter {p['name']} missing from the client"
        assert params[p["name"]].kind == inspect.Parameter.KEYWORD_ONLY
        required = params[p["name"]].default is inspect.Parameter.empty
        assert required == bool(p.get("required")), f"{method}.{p['name']}: required differs"
    if method != "subscribe":  # Client.subscribe takes notification names: its own doc
        assert spec["summary"].strip() in fn.__doc__


def test_the_client_has_no_method_the_document_lacks():
    names = {m["name"] for m in source_document()["methods"]}
    for area, cls in client_module._AREAS.items():
        for verb in cls._verbs:
            name = f"{area}.{verb}"
            assert name in names or name in client_module.CLIENT_ONLY, f"client.{name} is not in openrpc.json"
    assert client_module._AREAS["scan"].wait.__doc__  # scan.wait: the client's own helper


def test_every_error_code_is_an_exception_class():
    for e in source_document()["x-error-codes"]:
        cls = getattr(gonio, e["name"])
        assert issubclass(cls, gonio.RpcError) and cls.code == e["code"]


def test_an_error_answer_becomes_its_class_with_errc_and_field():
    e = gonio.errors.from_answer({"code": -32006, "message": "geometries[2]: the arms collide",
                                  "data": {"errc": "plan_rejected", "field": "geometries[2]"}},
                                 "scan.submit")
    assert isinstance(e, gonio.PlanRejected)
    assert (e.code, e.errc, e.field, e.method) == (-32006, "plan_rejected", "geometries[2]", "scan.submit")
    assert "[field geometries[2]]" in str(e)
    unknown = gonio.errors.from_answer({"code": -32099, "message": "new"})
    assert type(unknown) is gonio.RpcError and unknown.code == -32099


def test_unknown_and_missing_parameters_are_refused_naming_the_field():
    spec = gonio.methods()["sample.create"]
    with pytest.raises(gonio.InvalidParams) as e:
        client_module.checked_params(spec, {"name": "x", "colour": "red"})
    assert e.value.field == "colour"
    with pytest.raises(gonio.InvalidParams) as e:
        client_module.checked_params(spec, {"notes": "n"})
    assert e.value.field == "name"
    assert client_module.checked_params(spec, {"name": "x", "bsdf": None, "notes": gonio.OMIT}) == \
        {"name": "x", "bsdf": None}


def test_urls():
    parse = gonio.transport.parse_url
    assert parse("unix:///run/gonio/goniod.sock").path == "/run/gonio/goniod.sock"
    assert parse("unix:/var/lib/gonio/goniod.sock").path == "/var/lib/gonio/goniod.sock"
    a = parse("tcp://127.0.0.1:7700")
    assert (a.scheme, a.host, a.port) == ("tcp", "127.0.0.1", 7700)
    assert parse("http://localhost:7701/rpc").port == 7701
    assert parse("tls://goniod.lab:7444").secure and not parse("tls://goniod.lab:7444").http
    assert parse("https://goniod.lab:7443").secure and parse("https://goniod.lab:7443").http
    for bad in ("tcp://host", "ftp://h:1", "unix:", "http://h:1/other"):
        with pytest.raises(ValueError):
            parse(bad)


def test_the_progress_bar_is_gonioctls():
    # tests/unit/daemon/ctl/format_test.cpp, the same figures
    assert gonio.bar_text(5, 10, 65, 2, 10) == "[#####·····]  5/10   50 %  ETA 1:05  diverged 2"
    assert gonio.bar_text(10, 10, 3, 0, 4) == "[####] 10/10  100 %  ETA 0:00  diverged 0"
    assert gonio.bar_text(0, 0, 0, 0, 2) == "[··] 0/0    0 %  ETA 0:00  diverged 0"


def test_points_become_arrays_and_a_frame():
    def record(i, predicted=True):
        spec = {"wavelengths_nm": [400, 500, 600], "values": [0.1 * i, 0.2, 0.3],
                "std_uncertainty": [0.01, 0.01, 0.02]}
        return {"index": i, "geometry_index": i, "repeat": 0,
                "planned": {"theta_i": 45, "theta_r": 10.0 * i}, "actual": {"incidence": 45.0},
                "measured": spec, "predicted": dict(spec, std_uncertainty=[0.001] * 3) if predicted else None,
                "u_model": [0.002] * 3 if predicted else None, "z_max": 1.5 if predicted else None,
                "delta_e00": None, "diverged": False, "flags": [],
                "decision": "agrees" if predicted else None,
                "budget": [{"component": "arm", "contribution": [0.1, 0.2, 0.3]}] if predicted else []}
    pts = gonio.Points(1, [record(0), record(1), record(2, predicted=False)], 3, 3)
    a = pts.to_arrays()
    assert a["measured"].shape == (3, 3) and a["wavelength_nm"].tolist() == [400, 500, 600]
    assert a["theta_r"].tolist() == [0, 10, 20]
    assert a["budget"].shape == (3, 1, 3) and a["budget_components"] == ["arm"]
    import numpy as np
    assert np.isnan(a["predicted"][2]).all() and not np.isnan(a["predicted"][:2]).any()
    f = pts.to_frame()
    assert len(f) == 9
    assert list(f.columns[:8]) == ["index", "geometry_index", "repeat", "theta_i", "theta_r", "phi_i",
                                   "phi_r", "wavelength_nm"]
    row = f[(f["index"] == 1) & (f["wavelength_nm"] == 500)].iloc[0]
    assert (row["measured"], row["measured_u"], row["budget:arm"], row["decision"]) == (0.2, 0.01, 0.2, "agrees")
