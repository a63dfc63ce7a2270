"""python.notebook: executes a notebook against a real goniod on the mock, as a user would
run it, so that the example never rots.

    GONIO_BIN_DIR=build/ci/bin python3 python/tests/run_notebook.py examples/notebook.ipynb OUT.ipynb

nbclient runs every cell on an ipykernel of this interpreter (a kernel spec of its own in a
temporary JUPYTER_PATH, so whatever `python3` is first on PATH does not matter); a cell
that raises fails the run. The notebook must draw its plots (image/png outputs). The
executed notebook, outputs and all, is written to OUT.
"""
import json
import os
import sys
import tempfile
import time

import nbformat
from nbclient import NotebookClient

sys.path.insert(0, os.path.dirname(__file__))
from goniod_process import Goniod  # noqa: E402


def kernel_spec(root: str) -> str:
    d = os.path.join(root, "kernels", "gonio-python3")
    os.makedirs(d)
    with open(os.path.join(d, "kernel.json"), "w") as f:
        json.dump({"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                   "display_name": "Python 3 (gonio tests)", "language": "python"}, f)
    return "gonio-python3"


def main(notebook: str, output: str) -> int:
    with tempfile.TemporaryDirectory(prefix="gonio-nb-") as tmp:
        goniod = Goniod()
        try:
            os.environ.update(JUPYTER_PATH=tmp, JUPYTER_RUNTIME_DIR=os.path.join(tmp, "runtime"),
                              IPYTHONDIR=os.path.join(tmp, "ipython"), MPLCONFIGDIR=os.path.join(tmp, "mpl"),
                              GONIO_URL=goniod.url("tcp"), GONIO_TOKEN_FILE=goniod.token_file)
            nb = nbformat.read(notebook, as_version=4)
            client = NotebookClient(nb, kernel_name=kernel_spec(tmp), timeout=600,
                                    resources={"metadata": {"path": tmp}})
            t0 = time.monotonic()
            try:
                client.execute()
            finally:
                nbformat.write(nb, output)
            print(f"{notebook}: {len(nb.cells)} cells executed in {time.monotonic() - t0:.1f} s -> {output}")
        finally:
            goniod.close()
    images = sum(1 for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                 if "image/png" in o.get("data", {}))
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    if errors or images < 2:
        print(f"FAIL: {len(errors)} error outputs, {images} plots (expected 2 or more)", file=sys.stderr)
        return 1
    print(f"ok: {images} plots")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
