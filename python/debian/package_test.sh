#!/usr/bin/env bash
# deploy.python3_gonio: build_deb.sh makes python3-gonio, and the package holds the client in
# Debian's layout (the same modules as python/gonio, the same openrpc.json as proto/), root's,
# with the gonio source's changelog and copyright, Depends on python3, maintainer scripts that
# byte-compile and clean up; lintian reports no error and no warning; and the unpacked package
# imports under Debian's python3 with every method of the document; a second build is
# byte-identical.
#   package_test.sh PYTHON SOURCE_ROOT BUILD_DIR VERSION MAINTAINER
set -euo pipefail
py=$1 source=$2 build=$3 version=$4 maintainer=$5
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }
skip() { echo "SKIP: $*"; exit 77; }
for tool in dpkg-deb lintian; do
  command -v "$tool" >/dev/null || skip "$tool not found: .ci/bootstrap --test installs it"
done
{ "$py" -m pip --version && "$py" -c 'import setuptools, wheel'; } >/dev/null 2>&1 ||
  skip "$py lacks pip, setuptools or wheel (Debian: python3-pip, python3-setuptools, python3-wheel)"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
deb=$("$source/python/debian/build_deb.sh" "$py" "$source/python" "$build/deploy/debian/changelog.gz" \
        "$source/systemd/debian/copyright" "$version" "$maintainer" "$tmp/out")
[[ -f $deb && $(basename "$deb") == "python3-gonio_${version}_all.deb" ]] || { fail "no package: $deb"; exit 1; }

again=$("$source/python/debian/build_deb.sh" "$py" "$source/python" "$build/deploy/debian/changelog.gz" \
          "$source/systemd/debian/copyright" "$version" "$maintainer" "$tmp/again")
cmp -s "$deb" "$again" || fail "two builds of the same source differ (not reproducible)"

control=$(dpkg-deb -f "$deb")
field() { sed -n "s/^$1: //p" <<<"$control"; }
[[ $(field Package) == python3-gonio && $(field Source) == gonio ]] || fail "Package/Source: $(field Package)/$(field Source)"
[[ $(field Version) == "$version" && $(field Architecture) == all ]] || fail "Version/Architecture: $(field Version)/$(field Architecture)"
[[ $(field Maintainer) == "$maintainer" ]] || fail "Maintainer: $(field Maintainer)"
[[ $(field Depends) == *"python3:any"* ]] || fail "Depends: $(field Depends)"

listing=$(dpkg-deb -c "$deb")
awk '$2 != "root/root" { bad = 1; print "not root/root: " $0 } END { exit bad }' <<<"$listing" >&2 ||
  fail "entries not owned by root"
grep -q '__pycache__\|\.pyc$' <<<"$listing" && fail "bytecode in the package"
dpkg-deb -x "$deb" "$tmp/root"
site=$tmp/root/usr/lib/python3/dist-packages
for f in "$source"/python/gonio/*.py; do
  cmp -s "$f" "$site/gonio/$(basename "$f")" || fail "gonio/$(basename "$f") differs from python/gonio's"
done
cmp -s "$source/proto/openrpc.json" "$site/gonio/openrpc.json" || fail "gonio/openrpc.json is not proto/openrpc.json"
[[ -f $site/gonio-$version.dist-info/METADATA ]] || fail "no gonio-$version.dist-info"
cmp -s "$build/deploy/debian/changelog.gz" "$tmp/root/usr/share/doc/python3-gonio/changelog.gz" || fail "changelog.gz"
cmp -s "$source/systemd/debian/copyright" "$tmp/root/usr/share/doc/python3-gonio/copyright" || fail "copyright"
dpkg-deb -e "$deb" "$tmp/control"
for s in postinst prerm; do
  [[ -x $tmp/control/$s ]] && sh -n "$tmp/control/$s" || fail "$s missing or not valid sh"
done
grep -q 'py3compile -p python3-gonio' "$tmp/control/postinst" || fail "postinst does not byte-compile"
grep -q 'py3clean -p python3-gonio' "$tmp/control/prerm" || fail "prerm does not clean up"

out=$(cd "$tmp" && PYTHONPATH=$site PYTHONDONTWRITEBYTECODE=1 "$py" -c '
import gonio, json, sys
doc = json.load(open(sys.argv[1]))
missing = [m["name"] for m in doc["methods"] if m["name"] not in gonio.methods()]
print("methods", len(gonio.methods()), "missing", missing, "module", gonio.__file__)
' "$source/proto/openrpc.json" 2>&1) || fail "the unpacked package does not import: $out"
[[ $out == *"missing []"* && $out == *"$site/gonio/__init__.py"* ]] || fail "the unpacked package: $out"
(cd "$tmp" && PYTHONPATH=$site "$py" -m gonio --help >/dev/null) || fail "python3 -m gonio --help fails"

# --fail-on: the exit status counts errors and warnings only; -I shows the rest.
lint=$(lintian --fail-on error,warning --info --display-info "$deb" 2>&1) && rc=0 || rc=$?
printf '%s\n' "$lint" | grep -E '^[EWIP]: ' || true
((rc == 0)) || fail "lintian reports errors or warnings (status $rc): $(grep -E '^[EW]: ' <<<"$lint")"

if ((failures > 0)); then echo "$failures check(s) failed" >&2; exit 1; fi
echo "ok: $(basename "$deb") lintian-clean"
