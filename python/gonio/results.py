"""Results as data: a scan's points (paged transparently), its exports and its fits.

numpy and pandas are imported when a method needs them (to_arrays, to_frame), so the
package itself needs the standard library only.
"""
from __future__ import annotations

import collections.abc
import io
import json
import os

from .client import OMIT, checked_params
from .errors import by_name

Unsupported = by_name("Unsupported")

PAGE = 250  # points per scan.points call: ~2.4 MB of JSON at 31 channels with budgets


def points(client, spec, *, scan, offset=OMIT, limit=OMIT, page=PAGE, _timeout=None) -> "Points":
    """Returns a Points object holding every stored point from `offset` on (at most `limit`
    in all: here limit is not a page size), fetched in pages of `page` points (halved while
    an answer would pass goniod's server.max_response_bytes)."""
    checked_params(spec, {"scan": scan, "offset": offset, "limit": limit})
    off = 0 if offset is OMIT else offset
    records, last = [], {}
    while limit is OMIT or len(records) < limit:
        want = page if limit is OMIT else min(page, limit - len(records))
        try:
            last = client._call(spec.name, {"scan": scan, "offset": off, "limit": want}, _timeout, True)
        except Unsupported as e:
            if want <= 1 or "max_response_bytes" not in e.message:
                raise
            page = want // 2
            continue
        records += last["points"]
        if last.get("next_offset") is None or not last["points"]:
            break
        off = last["next_offset"]
    return Points(scan, records, last.get("points_done"), last.get("points_total"))


class Points(collections.abc.Sequence):
    """A scan's points: a sequence of PointRecord dicts (openrpc.json), with .to_arrays()
    (numpy) and .to_frame() (pandas, one row per point and wavelength)."""

    def __init__(self, scan: int, records: list, points_done=None, points_total=None):
        self.scan = scan
        self.records = records
        self.points_done = points_done
        self.points_total = points_total

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, i):
        return self.records[i]

    def __repr__(self) -> str:
        return f"<gonio.Points scan {self.scan}: {len(self)} of {self.points_total} points>"

    def to_arrays(self) -> dict:
        """numpy arrays by name. Per point (n): index, geometry_index, repeat, theta_i,
        theta_r, phi_i, phi_r (planned), actual_<axis> (read back), z_max, delta_e00,
        diverged, decision (str; '' without a prediction), integration_ms. Per channel
        (n × c): measured, measured_u (k = 1), predicted, predicted_se (the twin's Monte
        Carlo standard error), u_model (the twin's uncertainty from the instrument's stated
        tolerances); NaN without a prediction. wavelength_nm (c); budget (n × k × c: each
        component's contribution, budget_components (k) its names)."""
        import numpy as np
        recs = self.records
        wl = recs[0]["measured"]["wavelengths_nm"] if recs else []
        for r in recs:
            if r["measured"]["wavelengths_nm"] != wl:
                raise ValueError(f"point {r['index']} has other wavelengths than point {recs[0]['index']}")
        n, c = len(recs), len(wl)
        nan = float("nan")

        def per_point(get, dtype=float):
            return np.array([get(r) for r in recs], dtype=dtype).reshape(n)

        def per_channel(get):
            a = np.full((n, c), nan)
            for i, r in enumerate(recs):
                v = get(r)
                if v:
                    a[i] = v
            return a

        out = {"wavelength_nm": np.array(wl, dtype=float)}
        for k in ("index", "geometry_index", "repeat"):
            out[k] = per_point(lambda r, k=k: r[k], np.int64)
        for k in ("theta_i", "theta_r", "phi_i", "phi_r"):
            out[k] = per_point(lambda r, k=k: r["planned"].get(k, 0.0))
        axes = sorted({k for r in recs for k, v in (r.get("actual") or {}).items() if isinstance(v, (int, float))})
        for k in axes:
            out["actual_" + k] = per_point(lambda r, k=k: (r.get("actual") or {}).get(k, nan))
        out["measured"] = per_channel(lambda r: r["measured"]["values"])
        out["measured_u"] = per_channel(lambda r: r["measured"]["std_uncertainty"])
        out["predicted"] = per_channel(lambda r: (r.get("predicted") or {}).get("values"))
        out["predicted_se"] = per_channel(lambda r: (r.get("predicted") or {}).get("std_uncertainty"))
        out["u_model"] = per_channel(lambda r: r.get("u_model"))
        out["z_max"] = per_point(lambda r: nan if r.get("z_max") is None else r["z_max"])
        out["delta_e00"] = per_point(lambda r: nan if r.get("delta_e00") is None else r["delta_e00"])
        out["diverged"] = per_point(lambda r: bool(r.get("diverged")), bool)
        out["decision"] = per_point(lambda r: r.get("decision", ""), object)
        out["integration_ms"] = per_point(lambda r: r.get("integration_ms", nan))
        names = list(dict.fromkeys(b["component"] for r in recs for b in r.get("budget") or []))
        budget = np.full((n, len(names), c), nan)
        for i, r in enumerate(recs):
            for b in r.get("budget") or []:
                if b.get("contribution"):
                    budget[i, names.index(b["component"])] = b["contribution"]
        out["budget"], out["budget_components"] = budget, names
        return out

    def to_frame(self):
        """A pandas DataFrame with one row per point and wavelength: index, geometry_index,
        repeat, theta_i, theta_r, phi_i, phi_r, actual_<axis>, wavelength_nm, measured,
        measured_u, predicted, predicted_se, u_model, z_max, delta_e00, diverged, decision,
        integration_ms and budget:<component> (that component's contribution to the
        prediction's uncertainty at that wavelength)."""
        import numpy as np
        import pandas as pd
        a = self.to_arrays()
        n, c = len(self.records), len(a["wavelength_nm"])
        cols = {}
        for k, v in a.items():
            if k in ("wavelength_nm", "budget", "budget_components"):
                continue
            cols[k] = v.reshape(n * c) if v.ndim == 2 else np.repeat(v, c)
            if k == "phi_r":
                cols["wavelength_nm"] = np.tile(a["wavelength_nm"], n)
        for j, name in enumerate(a["budget_components"]):
            cols["budget:" + name] = a["budget"][:, j, :].reshape(n * c)
        return pd.DataFrame(cols)


def export(client, spec, *, scan, format=OMIT, offset=OMIT, limit=OMIT, _timeout=None) -> "Export":
    """Returns an Export: the whole file from `offset` on (csv and json come in chunks,
    called for until the last; at most `limit` points per chunk)."""
    params = checked_params(spec, {"scan": scan, "format": format, "offset": offset, "limit": limit})
    chunks, first = [], None
    while True:
        r = client._call(spec.name, params, _timeout, True)
        first = first or r
        chunks.append(r["content"])
        if r.get("next_offset") is None:
            break
        params["offset"] = r["next_offset"]
    return Export(scan, first["format"], first.get("filename", ""), first.get("media_type", ""),
                  "".join(chunks))


class Export:
    """A scan as a file: content (text), format, filename (goniod's suggestion), media_type;
    .save(path) writes it; .to_frame() reads a csv export into pandas."""

    def __init__(self, scan: int, format: str, filename: str, media_type: str, content: str):
        self.scan, self.format, self.filename, self.media_type = scan, format, filename, media_type
        self.content = content

    def __repr__(self) -> str:
        return f"<gonio.Export scan {self.scan} {self.format}: {len(self.content)} characters>"

    def save(self, path: str | os.PathLike | None = None) -> str:
        """Writes the file (default: goniod's filename in the current directory); returns its path."""
        path = os.fspath(path or self.filename)
        with open(path, "w", encoding="utf-8", newline="") as f:
            f.write(self.content)
        return path

    def to_frame(self):
        import pandas as pd
        if self.format == "csv":
            return pd.read_csv(io.StringIO(self.content), comment="#")  # its first line: "# gonio scan ..."
        raise ValueError(f"to_frame reads csv exports; this one is {self.format}")

    def json(self):
        """A json export parsed."""
        return json.loads(self.content)


def fit(client, spec, *, scan, model, samples=OMIT, max_iterations=OMIT, _timeout=None) -> "FitResult":
    """Returns a FitResult (default timeout: the client's, at least 300 s, as a fit is
    CPU-bound on goniod)."""
    params = checked_params(spec, {"scan": scan, "model": model, "samples": samples,
                                   "max_iterations": max_iterations})
    timeout = _timeout if _timeout is not None else max(client.timeout, 300.0)
    return FitResult(client._call(spec.name, params, timeout, False))


class FitResult:
    """A stored fit (schema Fit): id, scan, kind, model, record (the JSON) and its result
    (twin/fitting.md): parameters (name, value, u, ...), chi2_per_dof, converged, spec (the
    fitted model as a spec), warnings; .correlation() as a numpy matrix, .to_frame() the
    parameters as a pandas DataFrame."""

    def __init__(self, record: dict):
        self.record = record
        self.id, self.scan, self.kind, self.model = (record.get(k) for k in ("id", "scan", "kind", "model"))
        self.result = record.get("result") or {}

    def __getattr__(self, name):
        try:
            return self.__dict__["result"][name]
        except KeyError:
            raise AttributeError(name) from None

    def __repr__(self) -> str:
        ps = ", ".join(f"{p['name']}={p['value']:.4g}±{p.get('u', float('nan')):.2g}"
                       for p in self.result.get("parameters", []))
        return f"<gonio.FitResult {self.id} of scan {self.scan}: {ps}; χ²/dof {self.result.get('chi2_per_dof')}>"

    def correlation(self):
        import numpy as np
        return np.array(self.result.get("correlation", []), dtype=float)

    def to_frame(self):
        import pandas as pd
        return pd.DataFrame(self.result.get("parameters", []))
