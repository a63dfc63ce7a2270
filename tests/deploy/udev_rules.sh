#!/usr/bin/env bash
# 70-gonio.rules: well-formed udev rules (keys, operators, quoting, GOTO targets), each
# device rule tied to a VID:PID and giving group gonio mode 0660, ModemManager kept off the
# serial lines, and the /dev/gonio/ names exactly those of the installed configuration.
source "$(dirname "$0")/common.sh"

rules=$root$rulesdir/70-gonio.rules
config=$root$confdir/goniod.toml
[[ -f $rules && -f $config ]] || { fail "rules or configuration missing (deploy.install_tree did not run?)"; finish; }

match_only=" ACTION DEVPATH KERNEL KERNELS SUBSYSTEM SUBSYSTEMS DRIVER DRIVERS ATTR ATTRS SYSCTL TAGS TEST PROGRAM RESULT CONST "
assign_only=" OWNER GROUP MODE LABEL GOTO RUN OPTIONS IMPORT SECLABEL "
either=" NAME SYMLINK ENV TAG "
pair='^[[:space:]]*([A-Z_]+)(\{[^}]+\})?[[:space:]]*(==|!=|\+=|-=|:=|=)[[:space:]]*"([^"]*)"[[:space:]]*(,|$)'

labels=() gotos=() symlinks=()
n=0 logical=""
while IFS= read -r line || [[ -n $line ]]; do
  n=$((n + 1))
  if [[ $line == *\\ ]]; then logical+="${line%\\} "; continue; fi
  logical+=$line
  rule=$logical
  logical=""
  [[ $rule =~ ^[[:space:]]*(#|$) ]] && continue
  declare -A got=()
  rest=$rule
  while [[ -n ${rest//[[:space:]]/} ]]; do
    if ! [[ $rest =~ $pair ]]; then
      fail "line $n: cannot parse '$rest'"
      break
    fi
    key=${BASH_REMATCH[1]} attr=${BASH_REMATCH[2]} op=${BASH_REMATCH[3]} value=${BASH_REMATCH[4]}
    rest=${rest:${#BASH_REMATCH[0]}}
    if [[ $match_only == *" $key "* ]]; then
      [[ $op == "==" || $op == "!=" ]] || fail "line $n: $key can only be matched, not '$op'"
    elif [[ $assign_only == *" $key "* ]]; then
      [[ $op != "==" && $op != "!=" ]] || fail "line $n: $key can only be assigned, not '$op'"
    elif [[ $either != *" $key "* ]]; then
      fail "line $n: unknown key $key"
    fi
    got["$key$attr"]=$value
    case $key in
      LABEL) labels+=("$value") ;;
      GOTO) gotos+=("$value") ;;
      SYMLINK) symlinks+=("$value") ;;
    esac
    if [[ $attr == "{idVendor}" || $attr == "{idProduct}" ]]; then
      [[ $value =~ ^[0-9a-f]{4}$ ]] || fail "line $n: $key$attr \"$value\" is not 4 lower-case hex digits (as sysfs writes it)"
    fi
  done
  if [[ -n ${got[GROUP]+x} ]]; then
    [[ ${got[GROUP]} == gonio-dev ]] || fail "line $n: GROUP=\"${got[GROUP]}\", expected gonio-dev (not gonio: its members only get gonioctl)"
    [[ ${got[MODE]:-} == 0660 ]] || fail "line $n: GROUP without MODE=\"0660\""
    [[ -n ${got[ATTRS{idVendor}]:-${got[ATTR{idVendor}]:-}} && -n ${got[ATTRS{idProduct}]:-${got[ATTR{idProduct}]:-}} ]] ||
      fail "line $n: a device rule must match idVendor and idProduct"
  fi
  if [[ ${got[SUBSYSTEM]:-} == tty ]]; then
    [[ ${got[ENV{ID_MM_DEVICE_IGNORE}]:-} == 1 ]] || fail "line $n: serial line without ENV{ID_MM_DEVICE_IGNORE}=\"1\""
  fi
  unset got
done <"$rules"
[[ -z $logical ]] || fail "the file ends in a continued line"

for g in "${gotos[@]}"; do
  [[ " ${labels[*]} " == *" $g "* ]] || fail "GOTO=\"$g\" has no LABEL"
done

# Both ways: the configuration's /dev/gonio/ devices are exactly the rules' symlinks.
provided=$(printf '/dev/%s\n' "${symlinks[@]}" | sort -u)
used=$(grep -o '"/dev/gonio/[^"]*"' "$config" | tr -d '"' | sort -u)
[[ -n $used ]] || fail "$confdir/goniod.toml names no /dev/gonio/ device"
[[ $provided == "$used" ]] ||
  fail "udev symlinks and configured devices differ:"$'\n'"rules:  ${provided//$'\n'/ }"$'\n'"config: ${used//$'\n'/ }"

# udevadm verify (systemd 254 and later) is the parser itself.
if command -v udevadm >/dev/null && udevadm verify --help >/dev/null 2>&1; then
  out=$(udevadm verify --resolve-names=never "$rules" 2>&1) || fail "udevadm verify:"$'\n'"$out"
fi

finish
