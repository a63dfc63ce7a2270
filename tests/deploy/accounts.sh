#!/usr/bin/env bash
# sysusers.d and tmpfiles.d applied to an empty root, as postinst applies them: the system
# user gonio in group dialout, and /etc/gonio and /var/lib/gonio with their owners and modes.
source "$(dirname "$0")/common.sh"

command -v systemd-sysusers >/dev/null && command -v systemd-tmpfiles >/dev/null ||
  skip "systemd-sysusers or systemd-tmpfiles not found: install the Debian package systemd"
((EUID == 0)) || skip "systemd-tmpfiles needs root to give files to user gonio"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
t=$tmp/root
mkdir -p "$t/etc"
install -D -m 644 "$root$sysusersdir/gonio.conf" "$t$sysusersdir/gonio.conf"
install -D -m 644 "$root$tmpfilesdir/gonio.conf" "$t$tmpfilesdir/gonio.conf"
install -D -m 644 "$root$confdir/goniod.toml" "$t$confdir/goniod.toml"

out=$(systemd-sysusers --root="$t" gonio.conf 2>&1) || fail "systemd-sysusers: $out"
IFS=: read -r name _ uid gid _ home shell < <(grep '^gonio:' "$t/etc/passwd" || true)
[[ $name == gonio ]] || { fail "no user gonio in /etc/passwd"; finish; }
((uid > 0 && uid < 1000)) || fail "gonio has uid $uid: not a system user"
[[ $home == /var/lib/gonio ]] || fail "gonio's home is $home"
[[ $shell == */nologin ]] || fail "gonio's shell is $shell"
grep -q "^gonio:x:$gid:" "$t/etc/group" || fail "gonio's primary group is not gonio"
grep -Eq '^dialout:x:[0-9]+:(.*,)?gonio(,.*)?$' "$t/etc/group" || fail "gonio is not in group dialout"
grep -Eq '^gonio-dev:x:[0-9]+:(.*,)?gonio(,.*)?$' "$t/etc/group" || fail "gonio is not in group gonio-dev (the device nodes')"

out=$(systemd-tmpfiles --root="$t" --create gonio.conf 2>&1) || fail "systemd-tmpfiles: $out"
owner() { stat -c '%a %u %g' "$t$1"; }
[[ $(owner "$confdir") == "750 0 $gid" ]] || fail "$confdir: $(owner "$confdir"), expected 750 root gonio"
[[ $(owner "$confdir/goniod.toml") == "640 0 $gid" ]] ||
  fail "$confdir/goniod.toml: $(owner "$confdir/goniod.toml"), expected 640 root gonio"
[[ $(owner /var/lib/gonio) == "750 $uid $gid" ]] ||
  fail "/var/lib/gonio: $(owner /var/lib/gonio), expected 750 gonio gonio"

finish
