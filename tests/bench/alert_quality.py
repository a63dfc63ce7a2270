#!/usr/bin/env python3
"""Alert quality of goniod's divergence verdicts on the mock instrument.

Runs many seeded mock scans per scenario, each against a real goniod (its own state
directory and mock lab, the hidden truth drawn per scan), and reports per scenario how often
the sustained divergence alert fired and whether the verdict named the true cause:

  in spec         the sample is what the catalogue says, the instrument within its data
                  sheet (arm offsets drawn within ±0.45°, repeatability ±0.05°, the
                  white's gain within its certificate): every alert is a false alarm
  out of tolerance  the sample differs by about twice its tolerance or more: roughness
                  +10 %, one albedo band +4 % (tolerance 2 %), a coat's IOR 1.5 -> 1.6
  out of spec     the instrument is outside its data sheet: receive arm 1.5° off, the
                  reference white's gain 5 % off

Usage: tests/bench/alert_quality.py --bin build/release/bin [--scans 20] [--json]
"""
import argparse
import json
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time

GLOSSY = "conductor:alpha=0.05,eta=0.2,k=3.9"
PAINT = "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55"
COATED = "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55+coat:alpha=0.2,ior=1.5"
GLOSSY_GRID = "in=45;out=15:75:1"
MATTE_GRID = "in=45;out=-30:70:2"
COATED_GRID = "in=30;out=-15:75:2"

# name, class, catalogued spec, hidden true spec, grid, lab keys (a function of the rng),
# the parameter the verdict should name (None: no alert expected)
SCENARIOS = [
    ("in spec, glossy", "in_spec", GLOSSY, GLOSSY, GLOSSY_GRID, "offsets", None),
    ("in spec, matte paint", "in_spec", PAINT, PAINT, MATTE_GRID, "offsets", None),
    ("roughness +10 %", "sample", GLOSSY, "conductor:alpha=0.055,eta=0.2,k=3.9", GLOSSY_GRID, "none",
     "conductor.alpha"),
    ("albedo band +4 % (2x tolerance)", "sample", PAINT,
     "lambert:albedo=400:0.06,500:0.12,600:0.468,700:0.55", MATTE_GRID, "none", "lambert.albedo@600"),
    ("coat IOR 1.5 -> 1.6", "sample", COATED, COATED.replace("ior=1.5", "ior=1.6"), COATED_GRID, "none",
     "coat.ior"),
    ("receive arm 1.5 deg off", "instrument", GLOSSY, GLOSSY, GLOSSY_GRID, "receive=1.5", "receive_arm_deg"),
    ("white gain 5 % off", "instrument", PAINT, PAINT, MATTE_GRID, "gain=1.05", "gain"),
]


def lab_keys(kind, rng):
    keys = ["full_scale_counts = 1e12", "position_repeatability_deg = 0.05", f"seed = {rng.randrange(1, 1 << 30)}"]
    if kind == "offsets":
        keys.append("arm_offsets_deg = {{ incidence = {:.3f}, receive = {:.3f} }}".format(
            rng.uniform(-0.45, 0.45), rng.uniform(-0.45, 0.45)))
        # the white's true value within its certificate (u = 0.3 % from 500 nm)
        keys.append("gain = {:.5f}".format(rng.gauss(1.0, 0.003)))
    elif kind.startswith("receive="):
        keys.append("arm_offsets_deg = {{ receive = {} }}".format(kind.split("=")[1]))
    elif kind.startswith("gain="):
        keys.append("gain = {}".format(kind.split("=")[1]))
    return "\n".join(keys)


class Conn:
    def __init__(self, path):
        self.s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.s.connect(path)
        self.f = self.s.makefile("rwb")
        self.next = 1

    def call(self, method, params=None):
        self.next += 1
        msg = {"jsonrpc": "2.0", "id": self.next, "method": method}
        if params is not None:
            msg["params"] = params
        self.f.write((json.dumps(msg) + "\n").encode())
        self.f.flush()
        while True:
            reply = json.loads(self.f.readline())
            if reply.get("id") == self.next:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]


def run_scan(binary, scenario, rng, wavelengths):
    name, cls, catalogued, hidden, grid, lab, expected = scenario
    with tempfile.TemporaryDirectory(prefix="gonio-alerts-") as state:
        config = os.path.join(state, "goniod.toml")
        with open(config, "w") as f:
            f.write('[server]\nlisten = []\n\n[instrument.motion]\ndriver = "mock"\n'
                    f'sample = "{hidden}"\ntime_scale = 0\n{lab_keys(lab, rng)}\n\n'
                    '[instrument.photometer]\ndriver = "mock"\n')
        log = open(os.path.join(state, "goniod.log"), "w")
        proc = subprocess.Popen([os.path.join(binary, "goniod"), "--state-dir", state, "--config", config],
                                stdout=log, stderr=log)
        try:
            sock = os.path.join(state, "goniod.sock")
            for _ in range(200):
                if os.path.exists(sock):
                    try:
                        c = Conn(sock)
                        c.call("system.info")
                        break
                    except (OSError, RuntimeError, ValueError):
                        pass
                time.sleep(0.05)
            else:
                raise RuntimeError("goniod did not start: " + open(os.path.join(state, "goniod.log")).read())
            c.call("sample.create", {"name": "s", "bsdf": catalogued, "tolerance": 0.02})
            scan = c.call("scan.submit", {"sample": "s", "grids": [grid], "wavelengths": wavelengths})["id"]
            t0 = time.time()
            while True:
                st = c.call("scan.get", {"scan": scan})
                if st["state"] in ("completed", "failed", "cancelled", "paused"):
                    break
                time.sleep(0.1)
            seconds = time.time() - t0
            alerts = c.call("alert.list", {"scan": scan})
            sustained = [a for a in alerts if a["kind"] == "sustained_divergence"]
            verdict = st.get("verdict") or {}
            cause = (verdict.get("cause") or {}).get("parameter")
            return {"scenario": name, "class": cls, "state": st["state"], "points": st["points_done"],
                    "diverged_points": st["points_diverged"], "alert": bool(sustained),
                    "decision": verdict.get("decision"), "cause": cause, "expected": expected,
                    "correct": expected is not None and cause == expected, "seconds": seconds,
                    "summary": verdict.get("summary", ""),
                    "alert_message": sustained[0]["message"] if sustained else None}
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            log.close()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True, help="directory of goniod")
    ap.add_argument("--scans", type=int, default=20, help="seeded scans per scenario")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--wavelengths", default="400:700:10")
    ap.add_argument("--only", default="", help="run the scenarios whose name contains this")
    ap.add_argument("--json", action="store_true", help="every scan's result as JSON lines")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    rows = []
    for sc in SCENARIOS:
        if a.only and a.only not in sc[0]:
            continue
        results = [run_scan(a.bin, sc, rng, a.wavelengths) for _ in range(a.scans)]
        if a.json:
            for r in results:
                print(json.dumps(r))
        n = len(results)
        alerts = sum(r["alert"] for r in results)
        correct = sum(r["correct"] for r in results if r["alert"])
        decisions = {}
        for r in results:
            decisions[r["decision"]] = decisions.get(r["decision"], 0) + 1
        rows.append((sc[0], sc[1], n, alerts, correct, decisions,
                     sum(r["seconds"] for r in results) / n))
        sys.stderr.write(f"{sc[0]}: {alerts}/{n} alerts, {correct} correct causes\n")
    print(f"{'scenario':34} {'class':10} {'scans':>5} {'alerts':>7} {'rate':>6} {'correct':>8}  verdicts")
    for name, cls, n, alerts, correct, decisions, secs in rows:
        rate = alerts / n
        corr = f"{correct}/{alerts}" if cls != "in_spec" else "-"
        print(f"{name:34} {cls:10} {n:5d} {alerts:7d} {100 * rate:5.0f}% {corr:>8}  "
              + ", ".join(f"{k}: {v}" for k, v in sorted(decisions.items(), key=lambda kv: str(kv[0])))
              + f"  ({secs:.1f} s/scan)")
    fa = [r for r in rows if r[1] == "in_spec"]
    det = [r for r in rows if r[1] != "in_spec"]
    if fa:
        print(f"false-alarm rate (in spec): {100 * sum(r[3] for r in fa) / sum(r[2] for r in fa):.1f} %")
    if det:
        detected = sum(r[3] for r in det)
        print(f"detection rate (out of tolerance or spec): {100 * detected / sum(r[2] for r in det):.1f} %")
        if detected:
            print(f"correct diagnoses among detected: {100 * sum(r[4] for r in det) / detected:.1f} %")


if __name__ == "__main__":
    main()
