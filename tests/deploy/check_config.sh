#!/usr/bin/env bash
# goniod --check-config, the installed program on the installed configuration, as an
# administrator runs it after editing /etc/gonio/goniod.toml: exit 0 and the configuration
# goniod would run with (which checks again as the same), the devices it names and whether
# they exist; a broken copy exits 2 naming the field and the allowed range, and nothing is
# opened or created either way.
source "$(dirname "$0")/common.sh"

goniod=$root$bindir/goniod
conf=$root$confdir/goniod.toml
[[ -x $goniod && -f $conf ]] || { fail "installed goniod or $confdir/goniod.toml missing (deploy.install_tree did not run?)"; finish; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

check() {  # check FILE: sets $out, $err, $rc
  out=$(cd "$tmp" && "$goniod" --check-config "$1" 2>"$tmp/err") && rc=0 || rc=$?
  err=$(cat "$tmp/err")
}

check "$conf"
((rc == 0)) || fail "the installed configuration does not pass (status $rc): $err"
[[ -z $err ]] || fail "stderr on a valid configuration: $err"
grep -q "^driver = \"modbus\"$" <<<"$out" || fail "the effective configuration lacks the modbus driver:"$'\n'"$out"
grep -q '^min_separation = 8.0$' <<<"$out" || fail "instrument.limits.min_separation is not printed"
grep -q '^max_connections = 512$' <<<"$out" || fail "a default (server.max_connections) is not filled in"
for dev in arms photometer; do
  line=$(grep "^# device .* = /dev/gonio/$dev: " <<<"$out") || { fail "/dev/gonio/$dev is not reported"; continue; }
  if [[ -e /dev/gonio/$dev ]]; then
    [[ $line == *": present"* ]] || fail "present /dev/gonio/$dev reported as: $line"
  else
    [[ $line == *": missing"* ]] || fail "missing /dev/gonio/$dev reported as: $line"
  fi
done
# What it prints is a configuration that checks again to the same.
printf '%s\n' "$out" >"$tmp/effective.toml"
check "$tmp/effective.toml"
((rc == 0)) || fail "the printed configuration does not pass: $err"
diff <(grep -v '^#' <<<"$out") <(grep -v '^#' "$tmp/effective.toml") >/dev/null ||
  fail "the printed configuration does not check to itself"
[[ -z $(ls -A "$tmp" | grep -vx 'err\|effective.toml') ]] || fail "--check-config created files: $(ls -A "$tmp")"

# Broken copies: exit 2, the file, the field and what is allowed.
bad() {  # bad SED-EXPRESSION FIELD WANTED-TEXT
  sed "$1" "$conf" >"$tmp/bad.toml"
  check "$tmp/bad.toml"
  ((rc == 2)) || fail "[$1] exited $rc, expected 2"
  [[ $err == "goniod: $tmp/bad.toml: "*"$2"*"$3"* ]] || fail "[$1] error does not name $2 and '$3': $err"
  [[ -z $out ]] || fail "[$1] printed a configuration"
}
bad 's/^baud = 115200$/baud = 7/' instrument.motion.links.bus.baud "allowed range"
bad 's/^min_separation = 8 .*/min_separation = 200/' instrument.limits.min_separation "[0, 179]"
bad 's/^z_threshold = 5.0$/z_treshold = 5.0/' divergence.z_treshold "unknown"
bad 's/^incidence = \[0, 80\]$/incidence = [10, 80]/' instrument.limits.incidence "homing"
bad 's/^driver = "scpi-serial".*/driver = "scpi-carrier-pigeon"/' instrument.photometer.driver "the drivers are"
check "$tmp/none.toml"
((rc == 2)) && [[ $err == *"$tmp/none.toml"* ]] || fail "a missing file: status $rc, $err"
"$goniod" --check-config "$conf" --state-dir "$tmp" >/dev/null 2>&1 && fail "--check-config with --state-dir is accepted"

finish
