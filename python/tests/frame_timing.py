"""The time for a 1,000-point scan of 31 wavelength channels to reach a pandas DataFrame.

    python3 python/tests/frame_timing.py BIN_DIR [--rounds 5] [--url unix|tcp|http]

Starts goniod on the mock from BIN_DIR (build/release/bin) in a temporary state dir, runs
one scan of 100 geometries × 10 repeats at 400:700:10 nm to its end, then — the figure —
times `client.scan.points(scan=ID).to_frame()` (paged scan.points, parsing, the frame) in
`--rounds` rounds on a fresh client each, and prints the median, the smallest and the
largest, with the part spent in scan.points and in to_frame.
"""
import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import gonio  # noqa: E402
from goniod_process import TRUE_SAMPLE, Goniod  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--url", choices=["unix", "tcp", "http"], default="unix")
    args = ap.parse_args()
    os.environ["GONIO_BIN_DIR"] = args.bin_dir
    d = Goniod()
    try:
        with gonio.connect(d.url(args.url), state_dir=d.state_dir, timeout=120) as c:
            c.sample.create(name="white", bsdf=TRUE_SAMPLE)
            t0 = time.monotonic()
            scan = c.scan.submit(sample="white", grids="in=45;out=-30:69:1", repeats=10,
                                 wavelengths="400:700:10", reference="start")["id"]
            c.scan.wait(scan=scan, progress=False)
            print(f"scan {scan}: 1000 points measured and predicted in {time.monotonic() - t0:.1f} s")
        fetch, frame, total = [], [], []
        for _ in range(args.rounds):
            with gonio.connect(d.url(args.url), state_dir=d.state_dir, timeout=120) as c:
                t0 = time.perf_counter()
                pts = c.scan.points(scan=scan)
                t1 = time.perf_counter()
                f = pts.to_frame()
                t2 = time.perf_counter()
            assert f.shape[0] == 31000, f.shape
            fetch.append(t1 - t0), frame.append(t2 - t1), total.append(t2 - t0)
        print(f"1000 points × 31 channels -> DataFrame {f.shape} over {args.url}, {args.rounds} rounds: "
              f"median {statistics.median(total):.3f} s (min {min(total):.3f}, max {max(total):.3f}); "
              f"scan.points {statistics.median(fetch):.3f} s, to_frame {statistics.median(frame):.3f} s")
    finally:
        d.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
