#!/usr/bin/env bash
# cpack builds the Debian package and dpkg-deb lists it: the installed tree under the same
# paths, owned by root, programs stripped; Depends with the shared libraries found by
# dpkg-shlibdeps, systemd and colord-data; the configured maintainer; /etc/gonio/goniod.toml
# a conffile; and the maintainer scripts, run against stand-in commands: account and
# directories before anything else, the unit through deb-systemd-helper / deb-systemd-invoke
# only, systemd and udev reloaded only where they run, the service never enabled or started
# by an installation, restarted by an upgrade only when the new goniod accepts the
# configuration. The package stays in $package_dir for deploy.lintian and deploy.upgrade.
source "$(dirname "$0")/common.sh"

for tool in cpack dpkg-deb dpkg-shlibdeps file; do
  command -v "$tool" >/dev/null || skip "$tool not found: .ci/bootstrap --release installs cmake, dpkg-dev and file"
done
[[ -d $root$bindir ]] || { fail "the installed tree is missing (deploy.install_tree did not run?)"; finish; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rm -rf "$package_dir"
if ! log=$(cd "$build" && cpack -G DEB -B "$package_dir" 2>&1); then
  fail "cpack failed:"$'\n'"$log"
  finish
fi
arch=$(dpkg --print-architecture)
deb=$package_dir/gonio_${version}_$arch.deb
[[ -f $deb ]] || { fail "no $deb; cpack wrote: $(ls "$package_dir")"; finish; }

# ---- control
control=$(dpkg-deb -f "$deb")
field() { sed -n "s/^$1: //p" <<<"$control"; }
[[ $(field Package) == gonio ]] || fail "Package: $(field Package)"
[[ $(field Version) == "$version" ]] || fail "Version: $(field Version), expected $version"
[[ $(field Architecture) == "$arch" ]] || fail "Architecture: $(field Architecture)"
maintainer=$(sed -n 's/^GONIO_PACKAGE_MAINTAINER:STRING=//p' "$build/CMakeCache.txt")
[[ $(field Maintainer) == "$maintainer" ]] ||
  fail "Maintainer: $(field Maintainer), expected GONIO_PACKAGE_MAINTAINER ($maintainer)"
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

# Stand-ins record their command lines; which reloads run depends on this machine. goniod
# stands in for --check-config: it fails when $tmp/config-bad exists.
mkdir "$tmp/bin"
for c in systemd-sysusers systemd-tmpfiles systemctl udevadm deb-systemd-helper deb-systemd-invoke \
         goniod chown; do
  printf '#!/bin/sh\necho "%s $*" >>"%s"\n' "$c" "$tmp/calls" >"$tmp/bin/$c"
  chmod +x "$tmp/bin/$c"
done
printf '[ ! -e "%s" ]\n' "$tmp/config-bad" >>"$tmp/bin/goniod"
# deb-systemd-helper as on a machine where the unit was never installed nor enabled.
printf 'case "$*" in debian-installed*|*was-enabled*) exit 1;; esac\n' >>"$tmp/bin/deb-systemd-helper"
run() {  # run SCRIPT ARGS...: sets $calls to the commands it ran, one per line
  : >"$tmp/calls"
  PATH=$tmp/bin:$PATH sh "$tmp/control/$1" "${@:2}" >/dev/null 2>"$tmp/stderr" ||
    fail "$* exited with $?: $(cat "$tmp/stderr")"
  calls=$(cat "$tmp/calls")
}
systemd_up=false udev_up=false
[[ -d /run/systemd/system ]] && systemd_up=true
[[ -S /run/udev/control ]] && udev_up=true
dsh="deb-systemd-helper"

run postinst configure
want="systemd-sysusers gonio.conf"$'\n'"systemd-tmpfiles --create gonio.conf"
want+=$'\n'"$dsh debian-installed goniod.service"$'\n'"$dsh update-state goniod.service"
$systemd_up && want+=$'\n'"systemctl --system daemon-reload"
$udev_up && want+=$'\n'"udevadm control --reload"$'\n'"udevadm trigger --action=change --subsystem-match=tty --subsystem-match=usb"
[[ $calls == "$want" ]] || fail "postinst configure ran:"$'\n'"$calls"$'\n'"expected:"$'\n'"$want"

# The upgrade and removal branches for a running systemd: this machine's, or else (as root) a
# private mount namespace whose /run holds systemd/system, seen by the scripts only.
booted() {  # booted SCRIPT ARGS...: like run
  if $systemd_up; then run "$@"; return; fi
  : >"$tmp/calls"
  PATH=$tmp/bin:$PATH unshare -m sh -c 'mount -t tmpfs gonio-test /run && mkdir -p /run/systemd/system &&
    exec sh "$@"' sh "$tmp/control/$1" "${@:2}" >/dev/null 2>"$tmp/stderr" ||
    fail "$* exited with $? (under a private /run): $(cat "$tmp/stderr")"
  calls=$(cat "$tmp/calls")
}
can_boot=$systemd_up
if ! $can_boot && command -v unshare >/dev/null &&
   unshare -m sh -c 'mount -t tmpfs gonio-test /run' 2>/dev/null; then
  can_boot=true
fi
if $can_boot; then
  booted postinst configure 0.1.0
  grep -qx 'systemctl --system daemon-reload' <<<"$calls" || fail "an upgrade does not reload systemd: $calls"
  grep -qx 'goniod --check-config /etc/gonio/goniod.toml' <<<"$calls" ||
    fail "an upgrade does not check the configuration: $calls"
  grep -qx 'deb-systemd-invoke try-restart goniod.service' <<<"$calls" ||
    fail "an upgrade does not restart a running goniod: $calls"
  touch "$tmp/config-bad"
  booted postinst configure 0.1.0
  rm "$tmp/config-bad"
  grep -q 'deb-systemd-invoke' <<<"$calls" && fail "an upgrade restarts goniod on a configuration it refuses"
  grep -q 'check-config' "$tmp/stderr" || fail "a refused configuration is not reported: $(cat "$tmp/stderr")"
  booted postinst configure
  grep -E '^systemctl (enable|start|restart)|deb-systemd-invoke' <<<"$calls" &&
    fail "a first installation starts or enables goniod: $calls"
  booted prerm remove
  [[ $calls == 'deb-systemd-invoke stop goniod.service' ]] || fail "prerm remove does not stop goniod: $calls"
  booted prerm upgrade 0.2.1
  [[ -z $calls ]] || fail "prerm upgrade should leave goniod alone: $calls"
else
  echo "note: no systemd here and no private mount namespace (not root?): the branches for a running systemd are not run"
fi
run postinst configure 0.1.0
grep -E '^systemctl (enable|start|restart|stop|disable)|deb-systemd-invoke (start|restart)' <<<"$calls" &&
  fail "postinst enables or starts goniod"

# The TLS listeners' self-signed certificate: made by a first configure in /etc/gonio/tls
# (which tmpfiles.d makes), the key 0600 and the gonio user's, and left alone by the next one.
# Run with the real openssl in a private mount namespace whose /etc is an overlay, so that
# nothing of this machine's /etc changes.
if command -v openssl >/dev/null && unshare -m sh -c 'mount -t tmpfs gonio-test "$1"' sh "$tmp" 2>/dev/null; then
  mkdir "$tmp/etc"
  : >"$tmp/calls"
  out=$(PATH=$tmp/bin:$PATH unshare -m sh -c '
    mount -t tmpfs gonio-test "$1" && mkdir "$1/u" "$1/w" &&
    mount -t overlay overlay -o "lowerdir=/etc,upperdir=$1/u,workdir=$1/w" /etc && mkdir -p /etc/gonio/tls &&
    sh "$2" configure >/dev/null && stat -c "key %a" /etc/gonio/tls/goniod.key &&
    openssl x509 -in /etc/gonio/tls/goniod.pem -noout -checkend 86400 -ext subjectAltName &&
    before=$(sha256sum /etc/gonio/tls/goniod.pem) && sh "$2" configure 0.1.0 >/dev/null &&
    [ "$before" = "$(sha256sum /etc/gonio/tls/goniod.pem)" ] && echo kept' sh "$tmp/etc" "$tmp/control/postinst" 2>&1) ||
    fail "postinst's certificate:"$'\n'"$out"
  grep -qx 'key 600' <<<"$out" || fail "the self-signed key is not mode 0600: $out"
  grep -q 'Certificate will not expire' <<<"$out" || fail "the self-signed certificate is not valid for a day: $out"
  grep -q 'IP Address:127.0.0.1' <<<"$out" || fail "the self-signed certificate does not name 127.0.0.1: $out"
  grep -qx 'kept' <<<"$out" || fail "a second configure replaced the certificate: $out"
  grep -q '^chown gonio:gonio /etc/gonio/tls/goniod.key$' "$tmp/calls" ||
    fail "the key is not given to the gonio user: $(cat "$tmp/calls")"
else
  echo "note: no openssl or no private mount namespace (not root?): the self-signed certificate is not made here"
fi

# DPKG_ROOT: accounts and directories in that root, nothing of this machine touched.
DPKG_ROOT=$tmp/r run postinst configure 0.1.0
[[ $(head -2 <<<"$calls") == "systemd-sysusers --root=$tmp/r gonio.conf"$'\n'"systemd-tmpfiles --root=$tmp/r --create gonio.conf" ]] ||
  fail "postinst with DPKG_ROOT does not give the root to sysusers and tmpfiles: $calls"
grep -E '^(systemctl|deb-systemd-invoke|udevadm|goniod) ' <<<"$calls" &&
  fail "postinst with DPKG_ROOT touches this machine: $calls"

run prerm remove
grep -q '^systemctl ' <<<"$calls" && fail "prerm calls systemctl: $calls"
run postrm remove
grep -qx "$dsh mask goniod.service" <<<"$calls" || fail "postrm remove does not mask goniod: $calls"
grep -vE "^(systemctl --system daemon-reload|udevadm control --reload|$dsh mask goniod.service)$" <<<"$calls" |
  grep . && fail "postrm remove ran more than the reloads and the mask: $calls"
run postrm purge
[[ $calls == "$dsh purge goniod.service"$'\n'"$dsh unmask goniod.service" ]] ||
  fail "postrm purge: $calls"

finish
