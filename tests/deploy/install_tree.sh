#!/usr/bin/env bash
# `cmake --install` into a fresh DESTDIR puts every file where Debian expects it, with the
# expected mode and content, and nothing else. The tree stays for the other deploy tests.
source "$(dirname "$0")/common.sh"

rm -rf "$root"
DESTDIR=$root cmake --install "$build" >/dev/null
r=$root

expected=(
  "$bindir/goniod" "$bindir/gonioctl" "$bindir/gonio-twin" "$bindir/gonio-probe"
  "$unitdir/goniod.service" "$unitdir/gonio-backup.service" "$unitdir/gonio-backup.timer"
  "$rulesdir/70-gonio.rules"
  "$sysusersdir/gonio.conf"
  "$tmpfilesdir/gonio.conf"
  "$modulesloaddir/gonio.conf"
  "$confdir/goniod.toml"
  "$datadir/gonio/openrpc.json"
  "$mandir/man8/goniod.8.gz" "$mandir/man1/gonioctl.1.gz"
  "$mandir/man1/gonio-twin.1.gz" "$mandir/man1/gonio-probe.1.gz"
  "$docdir/README.md" "$docdir/daemon.md" "$docdir/drivers.md"
  "$docdir/bsdf_spec.md" "$docdir/bsdf_formats.md" "$docdir/colorimetry.md"
  "$docdir/scpi-gonio.md" "$docdir/errors.md"
  "$docdir/examples/goniod-hardware.toml" "$docdir/examples/goniod-mock.toml"
  "$docdir/copyright" "$docdir/changelog.gz"
)
# The dashboard as the build made it (hashed names), when it was built.
if [[ -n ${web_dist:-} ]]; then
  while IFS= read -r f; do expected+=("$datadir/gonio/web/$f"); done < <(cd "$web_dist" && find . -type f | sed 's|^\./||')
fi
# The whole tree, both ways: nothing missing, nothing else (gonio-devsim and gonio-load are
# development tools: cmake --install --component tools).
diff_out=$(diff <(printf '%s\n' "${expected[@]}" | sort) \
                <(cd "$r" && find . \( -type f -o -type l \) | sed 's/^\.//' | sort)) ||
  fail "installed tree differs from the expected one (< missing, > unexpected):"$'\n'"$diff_out"

for f in "${expected[@]}"; do
  [[ -e $r$f ]] || continue
  want=644
  [[ $f == "$bindir"/* ]] && want=755
  mode=$(stat -c %a "$r$f")
  [[ $mode == "$want" ]] || fail "$f has mode $mode, expected $want"
done

same() {  # same INSTALLED SOURCE
  cmp -s "$r$1" "$source/$2" || fail "$1 is not a copy of $2"
}
same "$rulesdir/70-gonio.rules" systemd/70-gonio.rules
if [[ -n ${web_dist:-} ]]; then
  cmp -s "$r$datadir/gonio/web/index.html" "$web_dist/index.html" || fail "the installed dashboard is not the built one"
fi
same "$sysusersdir/gonio.conf" systemd/sysusers.d/gonio.conf
same "$modulesloaddir/gonio.conf" systemd/modules-load.d/gonio.conf
same "$confdir/goniod.toml" daemon/examples/goniod-hardware.toml
same "$datadir/gonio/openrpc.json" proto/openrpc.json
same "$docdir/examples/goniod-mock.toml" daemon/examples/goniod-mock.toml

# The unit and tmpfiles.d name the installed program and configuration; with the prefix
# /usr they are the files in systemd/ unchanged.
unit=$r$unitdir/goniod.service
want_exec="ExecStart=$bindir/goniod --state-dir /var/lib/gonio --config $confdir/goniod.toml"
[[ $(grep '^ExecStart=' "$unit") == "$want_exec" ]] ||
  fail "installed unit: $(grep '^ExecStart=' "$unit"), expected $want_exec"
grep -q -- '--mock' "$unit" && fail "the installed unit runs the mock"
grep -q "^z $confdir/goniod.toml " "$r$tmpfilesdir/gonio.conf" ||
  fail "tmpfiles.d does not set the mode of $confdir/goniod.toml"
want_exec="ExecStart=$bindir/gonioctl --state-dir /var/lib/gonio backup --dir /var/backups/gonio --keep-daily 7 --keep-weekly 4"
[[ $(grep '^ExecStart=' "$r$unitdir/gonio-backup.service") == "$want_exec" ]] ||
  fail "installed gonio-backup.service: $(grep '^ExecStart=' "$r$unitdir/gonio-backup.service"), expected $want_exec"
grep -q "^d /var/backups/gonio 0750 gonio gonio " "$r$tmpfilesdir/gonio.conf" ||
  fail "tmpfiles.d does not make /var/backups/gonio for the nightly copies"
same "$unitdir/gonio-backup.timer" systemd/gonio-backup.timer
if [[ $prefix == /usr ]]; then
  same "$unitdir/goniod.service" systemd/goniod.service
  same "$unitdir/gonio-backup.service" systemd/gonio-backup.service
  same "$tmpfilesdir/gonio.conf" systemd/tmpfiles.d/gonio.conf
fi

# Man pages: gzip -9n (no file name, no time stamp) of the pages in the source tree.
for page in daemon/man/goniod.8 daemon/man/gonioctl.1 twin/man/gonio-twin.1 drivers/man/gonio-probe.1; do
  name=${page##*/}
  gz=$r$mandir/man${name##*.}/$name.gz
  [[ -f $gz ]] || continue
  cmp -s <(gzip -dc "$gz") "$source/$page" || fail "$gz does not decompress to $page"
  # Header: flags byte (no FNAME bit) and a zero modification time.
  flags=$(od -An -tu1 -j3 -N1 "$gz" | tr -d ' ')
  mtime=$(od -An -tu4 -j4 -N4 "$gz" | tr -d ' ')
  (( (flags & 8) == 0 && mtime == 0 )) || fail "$gz carries a file name or time stamp"
done

# Debian's two files of every package: the machine-readable copyright, and the changelog of
# this version (a native package's changelog.gz), gzip -9n like the man pages.
same "$docdir/copyright" systemd/debian/copyright
head -1 "$r$docdir/copyright" | grep -q '^Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/$' ||
  fail "$docdir/copyright is not in the machine-readable format"
if changelog=$(gzip -dc "$r$docdir/changelog.gz"); then
  [[ $(head -1 <<<"$changelog") == "gonio ($version) unstable; urgency=medium" ]] ||
    fail "changelog starts '$(head -1 <<<"$changelog")', expected version $version"
  maintainer=$(sed -n 's/^GONIO_PACKAGE_MAINTAINER:STRING=//p' "$build/CMakeCache.txt")
  trailer=$(grep '^ -- ' <<<"$changelog" || true)
  [[ $trailer == " -- $maintainer  "* ]] &&
    grep -Eq '  [A-Z][a-z]{2}, [0-9]{2} [A-Z][a-z]{2} [0-9]{4} [0-9:]{8} \+0000$' <<<"$trailer" ||
    fail "changelog trailer is not ' -- $maintainer  DATE' (RFC 2822):"$'\n'"$changelog"
  flags=$(od -An -tu1 -j3 -N1 "$r$docdir/changelog.gz" | tr -d ' ')
  ((flags & 8)) && fail "$docdir/changelog.gz carries a file name"
else
  fail "$docdir/changelog.gz is not gzip"
fi

# The installed programs run from the tree (no build-tree RPATH or missing library).
for exe in goniod gonioctl gonio-twin gonio-probe; do
  got=$("$r$bindir/$exe" --version 2>&1) || fail "$exe --version failed: $got"
  [[ $got == "$exe $version" ]] || fail "$exe --version printed '$got', expected '$exe $version'"
done
"$r$bindir/gonio-twin" --help >/dev/null || fail "gonio-twin --help failed"
"$r$bindir/gonio-probe" --help >/dev/null || fail "gonio-probe --help failed"

finish
