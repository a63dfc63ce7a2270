#!/usr/bin/env python3
"""Docs that run: every shell block of a document, executed as a reader would type it.

    run_doc_examples.py --bin BUILD/bin --root SOURCE [--timeout S] DOC.md

The ```sh, ```bash and ```shell blocks of DOC (and the `$ ` lines of ```console blocks) run
in order, one command at a time, in one bash in a fresh temporary directory, with --bin
first on PATH; a ```python block runs as one program among them, by the runner's own
interpreter (Debian's, as the Python client's tests; python/ on PYTHONPATH). A command that exits non-zero fails the test, naming the document, the line
and the command's output. What is substituted in every block:

- `build/release/bin` is --bin (the tree under test); `/tmp/gonio` is a directory in the
  temporary one (so `/tmp/gonio-lab` is too). The blocks run in TMP/root, and TMP/shared is
  the repository's sibling data directory, so `../shared/...` names what it names from the
  repository root.
- A reader waits for a prompt; the runner waits where that matters: after a command that
  starts `goniod ... &`, until that goniod answers `gonioctl info` on its state dir; after
  `kill ... %N`, until job N has exited.

A block that cannot run as it is says so in an HTML comment line right before its fence
(several lines stack; the reason is shown to readers of the Markdown source and counted in
the summary):

    <!-- doc-test: skip REASON -->           not run (installs packages, builds a tree, ...)
    <!-- doc-test: replace "OLD" "NEW" WHY --> run with OLD replaced (smaller settings, ...)
    <!-- doc-test: goniod [SPEC] -->          a goniod on the mock is started for it (and
                                              kept for later blocks; GONIO_STATE_DIR is its
                                              state dir), holding the BSDF SPEC (default: the
                                              demo sample, as `goniod --mock`)
    <!-- doc-test: expect-fail WHY -->        every command must exit non-zero

The last line is "DOC: N blocks, M commands run in B of them (S with substitutions), K skipped
(reasons)"; .ci/run prints these lines of every document.
"""
import argparse
import os
import pathlib
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time

SHELL_INFO = {"sh", "bash", "shell", "console", "python"}
ANNOTATION = re.compile(r"^<!--\s*doc-test:\s*(.*?)\s*-->\s*$")
OTHER_COMMENT = re.compile(r"^<!--.*-->\s*$")
MARK = "\x1edoc-test"


class Block:
    def __init__(self, doc, line, info):
        self.doc, self.line, self.info = doc, line, info
        self.lines = []  # (line number, text)
        self.skip = None
        self.replace = []
        self.goniod = None  # None, or the mock lab's sample ("" for goniod --mock's)
        self.expect_fail = False

    def commands(self):
        """(line, command) per logical command: comments and blank lines dropped, `\\`
        continuations joined; in a console block only `$ ` lines and their continuations."""
        out, current, start = [], None, 0
        if self.info == "python" and self.lines:
            body = "\n".join(text for _, text in self.lines)
            out = [(self.lines[0][0], f"{sys.executable} - <<'__DOC_PYTHON__'\n{body}\n__DOC_PYTHON__")]
        for number, text in self.lines if self.info != "python" else []:
            if self.info == "console":
                if current is None:
                    if not text.startswith("$ "):
                        continue
                    text = text[2:]
            if current is None:
                stripped = text.strip()
                if not stripped or stripped.startswith("#"):
                    continue
                current, start = text, number
            else:
                current += "\n" + text
            if not text.endswith("\\"):
                out.append((start, current))
                current = None
        if current is not None:
            out.append((start, current))
        for old, new in self.replace:
            if not any(old in c for _, c in out):
                raise SystemExit(f"{self.doc}:{self.line}: doc-test replace: '{old}' is not in the block")
            out = [(n, c.replace(old, new)) for n, c in out]
        return out


def parse_annotation(block, text, where):
    if text.startswith("skip"):
        block.skip = text[4:].strip() or "no reason given"
    elif text.startswith("replace"):
        args = shlex.split(text[7:])
        if len(args) < 2:
            raise SystemExit(f"{where}: doc-test replace needs \"OLD\" \"NEW\"")
        block.replace.append((args[0], args[1]))
    elif text.startswith("goniod"):
        block.goniod = text[6:].strip()
    elif text.startswith("expect-fail"):
        block.expect_fail = True
    else:
        raise SystemExit(f"{where}: unknown doc-test annotation '{text}' "
                         "(skip, replace, goniod, expect-fail)")


def blocks_of(doc, text):
    blocks, pending, fence, block = [], [], None, None
    for number, line in enumerate(text.splitlines(), 1):
        if block is not None:
            if line.strip() == fence:
                if block.info in SHELL_INFO:
                    blocks.append(block)
                block = None
            else:
                block.lines.append((number, line))
            continue
        m = re.match(r"^(\s*)(```+)\s*([\w-]*)", line)
        if m:
            fence = m.group(2)
            block = Block(doc, number, m.group(3).lower())
            for where, annotation in pending:
                parse_annotation(block, annotation, where)
            if pending and block.info not in SHELL_INFO:
                raise SystemExit(f"{pending[0][0]}: doc-test annotation before a ```{block.info} block")
            pending = []
        elif a := ANNOTATION.match(line):
            pending.append((f"{doc}:{number}", a.group(1)))
        elif not OTHER_COMMENT.match(line):
            if pending:
                raise SystemExit(f"{pending[0][0]}: doc-test annotation not followed by a code block")
            pending = []
    return blocks


def substitute(command, work, bin_dir):
    command = command.replace("build/release/bin", str(bin_dir))
    return re.sub(r"/tmp/gonio", f"{work}/gonio", command)


def script_for(blocks, work, bin_dir, goniod_dir):
    """The bash program: each command between markers carrying its line and exit status."""
    s = ["set +e", "exec 2>&1",
         "__doctest_wait_goniod() {  # $1 pid, $2 state dir",
         "  for __i in $(seq 1 200); do",
         "    gonioctl --state-dir \"$2\" info >/dev/null 2>&1 && return 0",
         "    kill -0 \"$1\" 2>/dev/null || { echo \"goniod exited at start\"; return 1; }",
         "    sleep 0.1",
         "  done; echo \"goniod did not answer on $2\"; return 1; }"]
    started = False
    for block in blocks:
        if block.skip:
            continue
        if block.goniod is not None and not started:
            started = True
            config = ""
            if block.goniod:
                config = f" --config {goniod_dir}.toml"
                s.append(f"cat > {goniod_dir}.toml <<'__LAB__'\n[instrument.motion]\ndriver = \"mock\"\n"
                         f"sample = \"{block.goniod}\"\ntime_scale = 0\n\n"
                         f"[instrument.photometer]\ndriver = \"mock\"\n__LAB__")
            s += [f"goniod --state-dir {goniod_dir} --mock{config} > {goniod_dir}.log 2>&1 &",
                  f"__doctest_wait_goniod $! {goniod_dir} || exit 96",
                  f"export GONIO_STATE_DIR={goniod_dir}"]
        for number, command in block.commands():
            command = substitute(command, work, bin_dir)
            s.append(f"printf '{MARK} start {number} %s\\n' $EPOCHREALTIME")
            s.append(command)
            s.append("__rc=$?")
            m = re.search(r"\bgoniod\b.*--state-dir\s+(\S+).*&\s*(#.*)?$", command)
            if m:
                s.append(f"__doctest_wait_goniod $! {m.group(1)} || __rc=95")
            if k := re.match(r"\s*kill\b.*%(\d+)", command):
                s.append(f"wait %{k.group(1)} 2>/dev/null")
            bad = "-eq" if block.expect_fail else "-ne"
            s.append(f"printf '{MARK} end {number} %d %s\\n' $__rc $EPOCHREALTIME")
            s.append(f"[ $__rc {bad} 0 ] && exit 97")
    s.append(f"printf '{MARK} done\\n'")
    return "\n".join(s) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", required=True, help="the build's bin directory")
    p.add_argument("--root", required=True, help="the source tree")
    p.add_argument("--timeout", type=float, default=300, help="seconds for the whole document")
    p.add_argument("doc", help="document, relative to --root")
    a = p.parse_args()
    root, bin_dir = pathlib.Path(a.root).resolve(), pathlib.Path(a.bin).resolve()
    blocks = blocks_of(a.doc, (root / a.doc).read_text())
    skipped = [b for b in blocks if b.skip]
    run = [b for b in blocks if not b.skip]
    lines = {}
    for b in run:
        for number, command in b.commands():
            lines[number] = (b, command)

    with tempfile.TemporaryDirectory(prefix="gonio-doc-") as work:
        env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", PYTHONPATH=str(root / "python"),
                   HOME=work, GONIO_SOURCE_DIR=str(root))
        env.pop("GONIO_STATE_DIR", None)
        script = script_for(blocks, work, bin_dir, f"{work}/goniod-mock")
        (pathlib.Path(work) / "doc-test.sh").write_text(script)
        (pathlib.Path(work) / "root").mkdir()
        if (root.parent / "shared").is_dir():
            (pathlib.Path(work) / "shared").symlink_to(root.parent / "shared")
        log_path = pathlib.Path(work) / "doc-test.log"
        started = time.monotonic()
        with open(log_path, "w") as log:
            proc = subprocess.Popen(["bash", "../doc-test.sh"], cwd=f"{work}/root", env=env, stdout=log,
                                    stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    start_new_session=True)
            try:
                proc.wait(timeout=a.timeout)
                timed_out = False
            except subprocess.TimeoutExpired:
                timed_out = True
            # Whatever the blocks left running (goniod &, the runner's goniod): TERM, then KILL.
            for sig in (signal.SIGTERM, signal.SIGKILL):
                try:
                    os.killpg(proc.pid, sig)
                except ProcessLookupError:
                    break
                time.sleep(0.5 if sig == signal.SIGTERM else 0)
            proc.wait()
        seconds = time.monotonic() - started

        output, current, ran, failure, timings = {}, None, 0, None, []
        for line in log_path.read_text(errors="replace").split("\n"):
            if line.startswith(MARK):
                words = line[len(MARK):].split()
                if words[0] == "start":
                    current = int(words[1])
                    output[current] = []
                    began = float(words[2])
                elif words[0] == "end":
                    ran += 1
                    rc = int(words[2])
                    timings.append((int(words[1]), float(words[3]) - began))
                    block = lines[int(words[1])][0]
                    if (rc == 0) == block.expect_fail:
                        failure = (int(words[1]), rc)
                    current = None
                continue
            if current is not None:
                output[current].append(line)
            elif failure is None and line:
                output.setdefault(0, []).append(line)
        done = f"{MARK} done" in log_path.read_text(errors="replace")

    def report(number, why):
        block, command = lines[number]
        print(f"FAIL {a.doc}:{number} (the block at line {block.line}): {why}\n  $ {command}")
        for l in output.get(number, [])[-60:]:
            print(f"  | {l}")

    ok = True
    if failure:
        number, rc = failure
        report(number, "exited 0 but the block expects a failure" if rc == 0
               else f"exited {rc}")
        ok = False
    elif timed_out:
        number = current if current is not None else max(output, default=0)
        if number in lines:
            report(number, f"still running after {a.timeout:.0f} s (the document's limit)")
        else:
            print(f"FAIL {a.doc}: still running after {a.timeout:.0f} s")
        ok = False
    elif not done:
        print(f"FAIL {a.doc}: the runner's script stopped early (exit {proc.returncode}):")
        for l in output.get(0, [])[-40:]:
            print(f"  | {l}")
        ok = False

    for number, took in timings:  # ctest -V shows where a document's time goes
        first = lines[number][1].split("\n")[0]
        print(f"  {a.doc}:{number} {took:6.1f} s  {first[:90]}")
    reasons = "; ".join(f"line {b.line}: {b.skip}" for b in skipped)
    smaller = sum(1 for b in run if b.replace)
    print(f"{a.doc}: {len(blocks)} blocks, {ran} commands run in {len(run)} of them ({smaller} with "
          f"substitutions), {len(skipped)} skipped" + (f" ({reasons})" if reasons else "") +
          f", {seconds:.0f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
