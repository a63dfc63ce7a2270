#!/usr/bin/env bash
# cpack builds the Debian package and dpkg-deb lists it: the installed tree under the same
# paths, owned by root, programs stripped; Depends with the shared libraries found by
# dpkg-shlibdeps, systemd and colord-data; /etc/gonio/goniod.toml a conffile; and the
# maintainer scripts, run against stand-in commands: account and directories before
# anything else, systemd and udev reloaded only where they run, the service never enabled.
source "$(dirname "$0")/common.sh"

for tool in cpack dpkg-deb dpkg-shlibdeps file; do
  command -v "$tool" >/dev/null || skip "$tool not found: .ci/bootstrap installs cmake, dpkg-dev and file"
done
[[ -d $root$bindir ]] || { fail "the installed tree is missing (deploy.install_tree did not run?)"; finish; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if ! log=$(cd "$build" && cpack -G DEB -B "$tmp/out" 2>&1); then
  fail "cpack failed:"$'\n'"$log"
  finish
fi
arch=$(dpkg --print-architecture)
deb=$tmp/out/gonio_${version}_$arch.deb
[[ -f $deb ]] || { fail "no $deb; cpack wrote: $(ls "$tmp/out")"; finish; }

# ---- control
control=$(dpkg-deb -f "$deb")
field() { sed -n "s/^$1: //p" <<<"$control"; }
[[ $(field Package) == gonio ]] || fail "Package: $(field Package)"
[[ $(field Version) == "$version" ]] || fail "Version: $(field Version), expected $version"
[[ $(field Architecture) == "$arch" ]] || fail "Architecture: $(field Architecture)"
depends=$(field Depends)
for dep in libc6 libstdc++6 libmodbus5 libusb-1.0-0 libsystemd0 libsqlite3-0 libcairo2 libssl3 \
           systemd colord-data; do
  [[ ", $depends," == *", $dep"[\ ,]* ]] || fail "Depends lacks $dep: $depends"
done
[[ ", $(field Recommends)," == *", udev,"* ]] || fail "Recommends lacks udev: $(field Recommends)"
echo "Depends: $depends"

# ---- contents: the same files as the DESTDIR install, all root's
listing=$(dpkg-deb -c "$deb")
diff_out=$(diff <(cd "$root" && find . \( -type f -o -type l \) | sed 's/^\.//' | sort) \
                <(awk '$1 !~ /^d/ { print $6 }' <<<"$listing" | sed 's/^\.//' | sort)) ||
  fail "package contents differ from the installed tree (< only installed, > only packaged):"$'\n'"$diff_out"
awk '$2 != "root/root" { bad = 1; print "not root/root: " $0 } END { exit bad }' <<<"$listing" >&2 ||
  fail "entries not owned by root"
grep -q '^-rwxr-xr-x .* \.'"$bindir"'/goniod$' <<<"$listing" || fail "goniod is not 0755 in the package"

mkdir "$tmp/data" "$tmp/control"
dpkg-deb -x "$deb" "$tmp/data"
dpkg-deb -e "$deb" "$tmp/control"
for exe in goniod gonioctl gonio-twin gonio-probe; do
  file -b "$tmp/data$bindir/$exe" | grep -q ', stripped' || fail "$exe is not stripped in the package"
done

# ---- conffiles and maintainer scripts
[[ $(cat "$tmp/control/conffiles" 2>/dev/null) == "$confdir/goniod.toml" ]] ||
  fail "conffiles: '$(cat "$tmp/control/conffiles" 2>/dev/null)', expected $confdir/goniod.toml"
for s in postinst prerm postrm; do
  [[ -x $tmp/control/$s ]] || { fail "no executable $s in the package"; continue; }
  cmp -s "$tmp/control/$s" "$source/systemd/debian/$s" || fail "$s is not systemd/debian/$s"
  sh -n "$tmp/control/$s" || fail "$s: syntax error"
done

# Stand-ins record their command lines; which reloads run depends on this machine.
mkdir "$tmp/bin"
for c in systemd-sysusers systemd-tmpfiles systemctl udevadm; do
  printf '#!/bin/sh\necho "%s $*" >>"%s"\n' "$c" "$tmp/calls" >"$tmp/bin/$c"
  chmod +x "$tmp/bin/$c"
done
run() {  # run SCRIPT ARGS...: sets $calls to the commands it ran, one per line
  : >"$tmp/calls"
  PATH=$tmp/bin:$PATH sh "$tmp/control/$1" "${@:2}" >/dev/null || fail "$* exited with $?"
  calls=$(cat "$tmp/calls")
}
systemd_up=false udev_up=false
[[ -d /run/systemd/system ]] && systemd_up=true
[[ -S /run/udev/control ]] && udev_up=true

run postinst configure
want="systemd-sysusers gonio.conf"$'\n'"systemd-tmpfiles --create gonio.conf"
$systemd_up && want+=$'\n'"systemctl daemon-reload"
$udev_up && want+=$'\n'"udevadm control --reload"$'\n'"udevadm trigger --action=change --subsystem-match=tty --subsystem-match=usb"
[[ $calls == "$want" ]] || fail "postinst configure ran:"$'\n'"$calls"$'\n'"expected:"$'\n'"$want"

run postinst configure 0.0.1
if $systemd_up; then
  grep -qx 'systemctl try-restart goniod.service' <<<"$calls" || fail "an upgrade does not restart a running goniod"
fi
grep -E 'systemctl (enable|start|restart) ' <<<"$calls" && fail "postinst enables or starts goniod"

run prerm remove
grep -qx 'systemctl disable --quiet goniod.service' <<<"$calls" || fail "prerm remove does not disable goniod: $calls"
run prerm upgrade 0.1.1
[[ -z $calls ]] || fail "prerm upgrade should leave goniod alone: $calls"
run postrm remove
grep -vE '^(systemctl daemon-reload|udevadm control --reload)$' <<<"$calls" | grep . &&
  fail "postrm remove ran more than the reloads: $calls"

finish
