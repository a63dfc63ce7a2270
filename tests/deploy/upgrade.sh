#!/usr/bin/env bash
# Upgrading gonio 0.1.0 to this version with dpkg, in a scratch root (dpkg --root with the
# maintainer scripts run chrootless, DPKG_ROOT set), over an installation an administrator
# has used: the conffile edited, the service enabled, and a store with a scan that goniod
# left interrupted when SIGTERM stopped it (what systemd does at the upgrade's restart).
# After the upgrade: the package is configured, the edited conffile kept (the new one
# beside it as .dpkg-dist) and judged by goniod --check-config, the enablement kept, the
# account there; the new goniod migrates the store to the current schema and finishes the
# scan, and every point committed before the upgrade is still there, unchanged.
#
# What stands for 0.1.0 (tests/deploy/data/gonio-0.1.0/, copied from the 0.1.0 release):
# - the package: 0.1.0's conffile, unit, sysusers.d and tmpfiles.d files and maintainer
#   scripts, without programs. Those are what dpkg's upgrade path handles; building 0.1.0's
#   programs would take longer than the whole deploy suite. 0.1.0's scripts do not honour
#   DPKG_ROOT, so they run against stand-ins and the test does in the root what they did.
# - the store: 0.1.0's schema (its migrations 1 and 2, verbatim) holding the rows this
#   version's goniod wrote for a scan it was stopped in; the copy fails if a table of
#   schema 2 has changed its columns since. Row formats older than this version are not
#   covered.
source "$(dirname "$0")/common.sh"

((EUID == 0)) || skip "dpkg --root and the gonio account in the root need root"
for tool in dpkg dpkg-deb dpkg-query sqlite3 deb-systemd-helper systemd-sysusers systemd-tmpfiles python3; do
  command -v "$tool" >/dev/null || skip "$tool not found: .ci/bootstrap --test installs it"
done
arch=$(dpkg --print-architecture)
deb=$package_dir/gonio_${version}_$arch.deb
[[ -f $deb ]] || { fail "no $deb (deploy.debian_package did not run?)"; finish; }
old=$source/tests/deploy/data/gonio-0.1.0

tmp=$(mktemp -d)
pid=""
cleanup() {
  [[ -n $pid ]] && kill -KILL "$pid" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT
R=$tmp/root

# ---- the 0.1.0 package
p=$tmp/old
install -D -m 644 "$old/goniod.toml" "$p/etc/gonio/goniod.toml"
install -D -m 644 "$old/goniod.service" "$p/usr/lib/systemd/system/goniod.service"
install -D -m 644 "$old/sysusers.conf" "$p/usr/lib/sysusers.d/gonio.conf"
install -D -m 644 "$old/tmpfiles.conf" "$p/usr/lib/tmpfiles.d/gonio.conf"
mkdir -p "$p/DEBIAN"
install -m 755 "$old/postinst" "$old/prerm" "$old/postrm" "$p/DEBIAN/"
echo /etc/gonio/goniod.toml >"$p/DEBIAN/conffiles"
cat >"$p/DEBIAN/control" <<END
Package: gonio
Version: 0.1.0
Architecture: $arch
Maintainer: $(dpkg-deb -f "$deb" Maintainer)
Description: goniometric spectrophotometer service (0.1.0's packaging files)
END
dpkg-deb --root-owner-group -b "$p" "$tmp/gonio_0.1.0.deb" >/dev/null || { fail "cannot build the 0.1.0 package"; finish; }

# ---- a scratch root with an empty dpkg database, 0.1.0 installed
mkdir -p "$R/var/lib/dpkg/info" "$R/var/lib/dpkg/updates" "$R/etc"
: >"$R/var/lib/dpkg/status"
: >"$R/var/lib/dpkg/available"
dpkg_root() {  # the libraries of Depends are this machine's, not the root's
  dpkg --root="$R" --force-script-chrootless --force-depends --force-confdef --force-confold "$@" \
    >>"$tmp/dpkg.log" 2>&1
}
mkdir "$tmp/stubs"
for c in systemd-sysusers systemd-tmpfiles systemctl udevadm; do
  printf '#!/bin/sh\nexit 0\n' >"$tmp/stubs/$c"
  chmod +x "$tmp/stubs/$c"
done
PATH=$tmp/stubs:$PATH dpkg_root -i "$tmp/gonio_0.1.0.deb" ||
  { fail "installing 0.1.0 failed:"$'\n'"$(cat "$tmp/dpkg.log")"; finish; }
systemd-sysusers --root="$R" gonio.conf >/dev/null 2>&1
systemd-tmpfiles --root="$R" --create gonio.conf >/dev/null 2>&1

# The administrator's changes: an edited conffile, the service enabled.
sed -i 's/^min_separation = 8 /min_separation = 9 /' "$R/etc/gonio/goniod.toml"
grep -q '^min_separation = 9 ' "$R/etc/gonio/goniod.toml" || fail "could not edit the conffile"
mkdir -p "$R/etc/systemd/system/multi-user.target.wants"
ln -s /usr/lib/systemd/system/goniod.service "$R/etc/systemd/system/multi-user.target.wants/goniod.service"

# ---- a store: goniod stopped by SIGTERM in a scan, copied into 0.1.0's schema
# Before the upgrade the mock moves and integrates in real time (about half a second a
# point), so that SIGTERM lands mid-scan; after it, at full speed.
for scale in 1 0; do
  printf '[instrument.motion]\ndriver = "mock"\ntime_scale = %s\n[instrument.photometer]\ndriver = "mock"\n' \
    "$scale" >"$tmp/mock-$scale.toml"
done
start() {  # start GONIOD STATE-DIR TIME-SCALE
  "$1" --state-dir "$2" --config "$tmp/mock-$3.toml" --listen "unix:$2/goniod.sock" >>"$tmp/goniod.log" 2>&1 &
  pid=$!
  for _ in $(seq 300); do
    [[ -S $2/goniod.sock ]] && return 0
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  fail "goniod did not start:"$'\n'"$(cat "$tmp/goniod.log")"
  finish
}
stop() {  # SIGTERM: the point in progress is finished and committed first
  kill -TERM "$pid"
  wait "$pid" && rc=0 || rc=$?
  pid=""
  ((rc == 0)) || fail "goniod exited with status $rc after SIGTERM:"$'\n'"$(cat "$tmp/goniod.log")"
}
field() { python3 -c 'import json, sys; print(json.load(sys.stdin)[sys.argv[1]])' "$1"; }
ctl() { "$root$bindir/gonioctl" --state-dir "$state" --json "$@"; }

state=$tmp/state
start "$root$bindir/goniod" "$state" 1
ctl sample create paint --bsdf 'lambert:albedo=0.5' >/dev/null || fail "sample create failed"
ctl scan submit --sample paint --grid 'in=30;out=-15:57:3' --wavelengths 400:700:100 >/dev/null ||
  fail "scan submit failed"
done_before=0
for _ in $(seq 600); do
  done_before=$(ctl scan get 1 | field points_done)
  ((done_before >= 2)) && break
  sleep 0.05
done
stop
db=$R/var/lib/gonio/goniod.db
sqlite3 "$db" <"$old/store-schema.sql" || fail "0.1.0's schema does not load"
copy="ATTACH '$state/goniod.db' AS cur;"
# Column by column as 0.1.0 named them: later versions add columns, never drop or rename one.
for t in samples scans points alerts audit tokens; do
  cols=$(sqlite3 "$db" "SELECT group_concat(name, ', ') FROM pragma_table_info('$t')")
  copy+="INSERT INTO main.$t ($cols) SELECT $cols FROM cur.$t;"
done
sqlite3 "$db" "$copy" || fail "the store does not copy into 0.1.0's schema (a released table changed?)"
query() { sqlite3 "$db" "$1"; }
[[ $(query 'PRAGMA user_version') == 2 ]] || fail "the old store is not at schema version 2"
before_state=$(query 'SELECT state FROM scans WHERE id = 1')
before_done=$(query 'SELECT points_done FROM scans WHERE id = 1')
before_points=$(query 'SELECT scan_id, idx, geometry_index, diverged, data FROM points ORDER BY scan_id, idx')
n_before=$(query 'SELECT count(*) FROM points')
[[ $before_state == interrupted ]] || fail "SIGTERM left the scan '$before_state', expected interrupted"
((before_done > 0 && before_done < 25)) || fail "the scan was not stopped mid-way: $before_done of 25 points"
((n_before == before_done)) || fail "points_done is $before_done, but $n_before points are stored"
samples_before=$(query 'SELECT id, name, bsdf FROM samples')

# ---- the upgrade
dpkg_root -i "$deb" || { fail "upgrading to $version failed:"$'\n'"$(cat "$tmp/dpkg.log")"; finish; }
status=$(dpkg-query --admindir="$R/var/lib/dpkg" -W -f='${Version} ${db:Status-Abbrev}' gonio)
[[ $status == "$version ii " ]] || fail "after the upgrade dpkg says: $status"
grep -q '^min_separation = 9 ' "$R/etc/gonio/goniod.toml" || fail "the edited conffile was replaced"
cmp -s "$R/etc/gonio/goniod.toml.dpkg-dist" "$source/daemon/examples/goniod-hardware.toml" ||
  fail "the new conffile is not beside the kept one as goniod.toml.dpkg-dist"
# 0.1.0's configuration still held the Modbus driver's own limit keys, which this version
# refuses (their values live in [instrument.limits]): a kept 0.1.0 conffile does not pass,
# and the check says which key and where it lives now. (postinst does not restart a running
# goniod on such a file; deploy.debian_package checks that.) The administrator's fix is to
# delete those keys.
out=$("$R$bindir/goniod" --check-config "$R/etc/gonio/goniod.toml" 2>&1) && rc=0 || rc=$?
((rc == 2)) && [[ $out == *"instrument.motion.min_separation_deg"*"[instrument.limits]"* ]] ||
  fail "the kept 0.1.0 conffile: --check-config status $rc, expected 2 naming min_separation_deg: $out"
sed -i -E '/^(min_separation_deg|min_deg|max_deg) = /d' "$R/etc/gonio/goniod.toml"
out=$("$R$bindir/goniod" --check-config "$R/etc/gonio/goniod.toml" 2>&1) ||
  fail "the kept conffile without the old keys does not pass goniod --check-config: $out"
grep -q '^min_separation = 9.0$' <<<"$out" || fail "--check-config does not show the edit"
[[ -L $R/etc/systemd/system/multi-user.target.wants/goniod.service ]] || fail "the upgrade disabled goniod"
DPKG_ROOT=$R DPKG_MAINTSCRIPT_PACKAGE=gonio deb-systemd-helper --quiet was-enabled goniod.service ||
  fail "deb-systemd-helper does not see goniod.service enabled in the root"
[[ -e $R/var/lib/systemd/deb-systemd-helper-enabled/goniod.service.dsh-also ]] ||
  fail "postinst did not record the unit's links (deb-systemd-helper update-state)"
grep -q '^gonio:' "$R/etc/passwd" || fail "no gonio account in the root"

# ---- the new goniod on the old store: migrated, the scan finished, nothing lost
state=$R/var/lib/gonio
start "$R$bindir/goniod" "$state" 0
for _ in $(seq 1200); do
  [[ $(ctl scan get 1 | field state) == completed ]] && break
  sleep 0.05
done
[[ $(ctl scan get 1 | field state) == completed ]] || fail "the interrupted scan did not finish after the upgrade"
stop
[[ $(query 'PRAGMA user_version') -gt 2 ]] || fail "the store was not migrated: version $(query 'PRAGMA user_version')"
query "SELECT 1 FROM sqlite_master WHERE name = 'fits'" | grep -q 1 || fail "the migrated store has no fits table"
query "SELECT count(*) FROM audit WHERE action = 'store.migrate'" | grep -qv '^0$' ||
  fail "the migration is not in the audit log"
[[ $(query 'SELECT count(*) FROM points WHERE scan_id = 1') == 25 ]] ||
  fail "the scan has $(query 'SELECT count(*) FROM points WHERE scan_id = 1') of 25 points"
[[ $(query "SELECT scan_id, idx, geometry_index, diverged, data FROM points WHERE idx < $before_done ORDER BY scan_id, idx") == "$before_points" ]] ||
  fail "points committed before the upgrade changed"
[[ $(query 'SELECT id, name, bsdf FROM samples') == "$samples_before" ]] || fail "the samples changed"

finish
