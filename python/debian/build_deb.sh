#!/usr/bin/env bash
# Builds the Debian package python3-gonio (Architecture: all) from python/: the wheel that
# Debian's pip builds offline from pyproject.toml, unpacked in Debian's layout
# (/usr/lib/python3/dist-packages), with the gonio source package's changelog and copyright.
# The maintainer scripts byte-compile at installation and clean up at removal, as
# dh_python3's do; no bytecode is shipped. The same source gives the same bytes.
#   build_deb.sh PYTHON SOURCE_DIR CHANGELOG_GZ COPYRIGHT VERSION MAINTAINER OUTPUT_DIR
set -euo pipefail
py=$1 src=$2 changelog=$3 copyright=$4 version=$5 maintainer=$6 out=$7
here=$(cd "$(dirname "$0")" && pwd)
# Reproducible: every time stamp is the changelog entry's date (unless SOURCE_DATE_EPOCH is
# set), so the same source gives the same bytes.
if [[ -z ${SOURCE_DATE_EPOCH:-} ]]; then
  SOURCE_DATE_EPOCH=$(date -d "$(gzip -dc "$changelog" | sed -n 's/^ -- .*>  //p' | head -n 1)" +%s)
fi
export SOURCE_DATE_EPOCH

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# A copy, so that the symlinked openrpc.json becomes a file and the build's by-products stay
# out of the source tree.
mkdir "$tmp/src"
cp -L "$src/pyproject.toml" "$src/README.md" "$tmp/src/"
cp -rL "$src/gonio" "$tmp/src/gonio"
find "$tmp/src" -name __pycache__ -prune -exec rm -rf {} +
PYTHONDONTWRITEBYTECODE=1 "$py" -m pip wheel --quiet --no-deps --no-build-isolation --no-index \
  --wheel-dir "$tmp/wheel" "$tmp/src"

root=$tmp/root
site=$root/usr/lib/python3/dist-packages
doc=$root/usr/share/doc/python3-gonio
mkdir -p "$site" "$doc" "$root/DEBIAN"
"$py" -m zipfile -e "$tmp"/wheel/gonio-"$version"-*.whl "$site"
install -m 0644 "$changelog" "$doc/changelog.gz"
install -m 0644 "$copyright" "$doc/copyright"
find "$root" -type d -exec chmod 0755 {} +
find "$root/usr" -type f -exec chmod 0644 {} +

size=$(du -sk --exclude=DEBIAN "$root" | cut -f1)
cat >"$root/DEBIAN/control" <<CONTROL
Package: python3-gonio
Source: gonio
Version: $version
Architecture: all
Maintainer: $maintainer
Installed-Size: $size
Depends: python3:any (>= 3.11~)
Recommends: python3-numpy, python3-pandas
Suggests: gonio, python3-matplotlib, python3-ipykernel
Section: python
Priority: optional
Description: Python client of goniod, the gonio spectrophotometer service
 The gonio package for Python 3: every method of goniod's JSON-RPC API as a
 Python method (made from its OpenRPC document), exceptions with goniod's
 stable error codes, connections over a Unix socket, TCP and HTTP with
 reconnection, a scan's points as numpy arrays and pandas data frames,
 waiting for scans with a progress bar, and notifications as iterators.
 python3 -m gonio is a small command line (status, submit, wait, export).
CONTROL
install -m 0755 "$here/postinst" "$here/prerm" "$root/DEBIAN/"
(cd "$root" && find usr -type f -print0 | sort -z | xargs -0 md5sum) >"$root/DEBIAN/md5sums"
chmod 0644 "$root/DEBIAN/md5sums"

find "$root" -exec touch -h -d "@$SOURCE_DATE_EPOCH" {} +
mkdir -p "$out"
dpkg-deb --root-owner-group -Zxz --build "$root" "$out/python3-gonio_${version}_all.deb" >/dev/null
echo "$out/python3-gonio_${version}_all.deb"
