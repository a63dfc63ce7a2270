#!/usr/bin/env bash
# The installed service's command line (ExecStart of the installed unit, pointed into the
# DESTDIR) on the installed configuration: goniod drives the configured Modbus arms and SCPI
# photometer, never the mock; while /dev/gonio/ does not exist it stays up, reports the
# instrument unavailable and answers gonioctl, and SIGTERM stops it with status 0.
source "$(dirname "$0")/common.sh"

[[ -e /dev/gonio ]] && skip "this machine has /dev/gonio: not starting goniod on real devices"
unit=$root$unitdir/goniod.service
[[ -f $unit ]] || { fail "$unit is missing (deploy.install_tree did not run?)"; finish; }

tmp=$(mktemp -d)
pid=""
cleanup() {
  [[ -n $pid ]] && kill -KILL "$pid" 2>/dev/null
  rm -rf "$tmp"
}
trap cleanup EXIT

read -ra argv <<<"$(sed -n 's/^ExecStart=//p' "$unit")"
args=()
for a in "${argv[@]}"; do
  case $a in
    "$bindir"/* | "$confdir"/*) args+=("$root$a") ;;
    /var/lib/gonio) args+=("$tmp/state") ;;
    --mock) fail "the installed unit runs the mock" ;;
    *) args+=("$a") ;;
  esac
done
# Only the state dir's socket: the configuration's TCP ports may be taken on this machine.
args+=(--listen "unix:$tmp/state/goniod.sock")

env -u JOURNAL_STREAM -u INVOCATION_ID -u NOTIFY_SOCKET -u WATCHDOG_USEC \
  "${args[@]}" >"$tmp/goniod.log" 2>&1 &
pid=$!
for _ in $(seq 200); do
  [[ -S $tmp/state/goniod.sock ]] && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.1
done
if ! kill -0 "$pid" 2>/dev/null; then
  wait "$pid" && rc=0 || rc=$?
  pid=""
  fail "goniod exited with status $rc on the installed configuration:"$'\n'"$(cat "$tmp/goniod.log")"
  finish
fi

ctl() { "$root$bindir/gonioctl" --state-dir "$tmp/state" --json "$@"; }
field() { python3 -c 'import json, sys; print(json.load(sys.stdin)[sys.argv[1]])' "$1"; }
if status=$(ctl instrument status); then
  [[ $(field motion_driver <<<"$status") == modbus ]] || fail "motion driver: $(field motion_driver <<<"$status")"
  [[ $(field photometer_driver <<<"$status") == scpi-serial ]] ||
    fail "photometer driver: $(field photometer_driver <<<"$status")"
  [[ $(field available <<<"$status") == False ]] || fail "the instrument is available without devices"
  [[ $(field error <<<"$status") == */dev/gonio/* ]] ||
    fail "the instrument error does not name the missing /dev/gonio/ device: $(field error <<<"$status")"
else
  fail "gonioctl instrument status failed"
fi
info=$(ctl info) || fail "gonioctl info failed"
[[ $info == *"\"$version\""* ]] || fail "gonioctl info does not report version $version: $info"

kill -TERM "$pid"
wait "$pid" && rc=0 || rc=$?
pid=""
((rc == 0)) || fail "goniod exited with status $rc after SIGTERM:"$'\n'"$(cat "$tmp/goniod.log")"

finish
