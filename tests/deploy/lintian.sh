#!/usr/bin/env bash
# lintian on the package that deploy.debian_package built: no error and no warning, with
# lintian's own overrides file (none is needed today: each one must say why in a comment).
# Informational tags are printed, not failed on.
source "$(dirname "$0")/common.sh"

command -v lintian >/dev/null || skip "lintian not found: .ci/bootstrap --test installs it"
deb=$package_dir/gonio_${version}_$(dpkg --print-architecture).deb
[[ -f $deb ]] || { fail "no $deb (deploy.debian_package did not run?)"; finish; }

# --fail-on: the exit status counts errors and warnings only; -I shows the rest.
out=$(lintian --fail-on error,warning --info --display-info "$deb" 2>&1) && rc=0 || rc=$?
printf '%s\n' "$out" | grep -E '^[EWIP]: ' || true
((rc == 0)) || fail "lintian reports errors or warnings (status $rc):"$'\n'"$(grep -E '^[EW]: ' <<<"$out")"
grep -E '^[EW]: ' <<<"$out" >/dev/null && fail "lintian printed errors or warnings"

finish
