#!/usr/bin/env bash
# The installed goniod.service: what the issue asks of it, `systemd-analyze verify` without a
# single message, and `systemd-analyze security` exposure at most 2.0.
source "$(dirname "$0")/common.sh"

unit=$root$unitdir/goniod.service
[[ -f $unit ]] || { fail "$unit is missing (deploy.install_tree did not run?)"; finish; }

# Settings the deployment relies on, which the security score does not look at.
for line in Type=notify NotifyAccess=main 'WatchdogSec=[1-9]' Restart=on-failure \
            'StartLimitIntervalSec=[1-9]' 'StartLimitBurst=[1-9]' User=gonio Group=gonio \
            StateDirectory=gonio RuntimeDirectory=gonio \
            DevicePolicy=closed 'DeviceAllow=char-ttyUSB rw' 'DeviceAllow=char-usb_device rw' \
            'CapabilityBoundingSet=$' 'SystemCallFilter=@system-service' \
            'RestrictAddressFamilies=' ProtectSystem=strict ProtectHome=yes PrivateTmp=yes \
            NoNewPrivileges=yes WantedBy=multi-user.target; do
  grep -q "^$line" "$unit" || fail "goniod.service has no line matching '^$line'"
done

command -v systemd-analyze >/dev/null ||
  skip "systemd-analyze not found: install the Debian package systemd (.ci/bootstrap does)"

# verify wants ExecStart's program and the Documentation= man pages to exist: check a copy
# of the installed unit whose ExecStart points into the DESTDIR, with man looking there.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sed "s#^ExecStart=$bindir/#ExecStart=$root$bindir/#" "$unit" >"$tmp/goniod.service"
grep -q "^ExecStart=$root$bindir/goniod " "$tmp/goniod.service" ||
  fail "ExecStart does not start $bindir/goniod"
if ! out=$(MANPATH=$root$mandir systemd-analyze verify "$tmp/goniod.service" 2>&1); then
  fail "systemd-analyze verify failed:"$'\n'"$out"
elif [[ -n $out ]]; then
  fail "systemd-analyze verify is not clean:"$'\n'"$out"
fi

# The nightly copy: a oneshot as goniod's user, its timer, both clean for verify.
backup=$root$unitdir/gonio-backup.service
for line in Type=oneshot User=gonio Group=gonio ProtectSystem=strict ReadWritePaths=/var/backups/gonio \
            "ExecStart=$bindir/gonioctl .* backup --dir /var/backups/gonio --keep-daily [0-9]* --keep-weekly [0-9]*"; do
  grep -q "^$line" "$backup" || fail "gonio-backup.service has no line matching '^$line'"
done
grep -q '^OnCalendar=' "$root$unitdir/gonio-backup.timer" || fail "gonio-backup.timer has no OnCalendar="
grep -q '^Persistent=true' "$root$unitdir/gonio-backup.timer" || fail "gonio-backup.timer does not catch up a missed night"
sed "s#^ExecStart=$bindir/#ExecStart=$root$bindir/#" "$backup" >"$tmp/gonio-backup.service"
cp "$root$unitdir/gonio-backup.timer" "$tmp/gonio-backup.timer"
if ! out=$(MANPATH=$root$mandir systemd-analyze verify "$tmp/gonio-backup.service" "$tmp/gonio-backup.timer" 2>&1); then
  fail "systemd-analyze verify of the backup units failed:"$'\n'"$out"
elif [[ -n $out ]]; then
  fail "systemd-analyze verify of the backup units is not clean:"$'\n'"$out"
fi

# --threshold is in tenths: 20 is an exposure of 2.0.
out=$(systemd-analyze security --offline=true --threshold=20 "$unit" 2>&1) && rc=0 || rc=$?
exposure=$(sed -n 's/.*Overall exposure level for goniod.service: \([0-9.]*\).*/\1/p' <<<"$out")
if [[ -z $exposure ]]; then
  fail "systemd-analyze security printed no exposure level:"$'\n'"$out"
elif ((rc != 0)); then
  fail "exposure $exposure is above 2.0:"$'\n'"$(grep '^✗' <<<"$out")"
fi
echo "exposure: ${exposure:-?}"

finish
