#!/usr/bin/env python3
"""The docs runner itself: a broken example fails naming the document, the line and the
output; a block that should fail and does not, fails; skips are counted with their reason;
a substitution whose text is not in its block is an error; a Python block is one program.
No goniod: plain shell blocks."""
import pathlib
import subprocess
import sys
import tempfile

runner = pathlib.Path(__file__).with_name("run_doc_examples.py")
failures = []


def run(doc_text):
    with tempfile.TemporaryDirectory() as root:
        (pathlib.Path(root) / "doc.md").write_text(doc_text)
        p = subprocess.run([sys.executable, runner, "--bin", root, "--root", root, "--timeout", "30",
                            "doc.md"], capture_output=True, text=True)
        return p.returncode, p.stdout + p.stderr


def check(name, doc_text, want_rc, *want):
    rc, out = run(doc_text)
    missing = [w for w in want if w not in out]
    if rc != want_rc or missing:
        failures.append(f"{name}: exit {rc} (want {want_rc}), missing {missing}:\n{out}")


F = "```"
check("passes", f"# t\n\n{F}sh\nx=1\necho $x > one.txt\ncat one.txt \\\n  one.txt\n{F}\n", 0,
      "doc.md: 1 blocks, 3 commands run in 1 of them (0 with substitutions), 0 skipped")
check("a failing command", f"# t\n\n{F}sh\necho fine\nls no-such-file\necho never\n{F}\n", 1,
      "FAIL doc.md:5 (the block at line 3): exited 2", "$ ls no-such-file", "no-such-file",
      "2 commands run")
check("expect-fail that succeeds", f"<!-- doc-test: expect-fail -->\n{F}sh\ntrue\n{F}\n", 1,
      "FAIL doc.md:3", "expects a failure")
check("expect-fail that fails", f"<!-- doc-test: expect-fail -->\n{F}sh\nfalse\n{F}\n", 0,
      "1 commands run")
check("skip counted", f"<!-- doc-test: skip needs root -->\n{F}sh\napt-get install x\n{F}\n"
      f"{F}bash\necho a\n{F}\n", 0, "2 blocks, 1 commands run in 1 of them", "1 skipped (line 2: needs root)")
check("replace", f'<!-- doc-test: replace "1 = 2" "2 = 2" -->\n{F}sh\ntest 1 = 2\n{F}\n', 0,
      "(1 with substitutions)")
check("replace of absent text", f'<!-- doc-test: replace "nowhere" "x" -->\n{F}sh\ntrue\n{F}\n', 1,
      "'nowhere' is not in the block")
check("console block", f"{F}console\n$ echo hi\nhi\n$ false\n{F}\n", 1, "FAIL doc.md:4")
check("other languages are not run", f"{F}toml\nfalse\n{F}\n{F}\nfalse\n{F}\n", 0, "0 blocks")
check("a python block is one program", f"{F}python\nimport sys\nprint('py ok')\nsys.exit(3)\n{F}\n", 1,
      "FAIL doc.md:2", "exited 3", "py ok")
for f in failures:
    print(f)
print(f"{10 - len(failures)} of 10 runner checks passed")
sys.exit(1 if failures else 0)
