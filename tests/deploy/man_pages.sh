#!/usr/bin/env bash
# The man pages: no groff warnings, the project's version in the title line, and every
# command and option that the installed program's --help lists (recursively through its
# subcommands) documented.
source "$(dirname "$0")/common.sh"

command -v groff >/dev/null || skip "groff not found: install the Debian package groff-base"

# Every long and short option and every subcommand in `PROGRAM [SUBCOMMAND...] --help`.
help_words() {
  local help
  help=$("$@" --help) || { local IFS=+; echo "!$*"; return; }  # a subshell: the caller reports it
  grep -oE -- '(^|[^[:alnum:]-])--[a-z][a-z0-9-]*' <<<"$help" | sed 's/^[^-]*//'
  grep -oE -- '^ +-[a-zA-Z],' <<<"$help" | tr -d ' ,'
  local sub
  for sub in $(awk '/^Subcommands:/ { on = 1; next } on && /^  [a-z]/ { print $1 } on && /^$/ { on = 0 }' <<<"$help"); do
    echo "$sub"
    help_words "$@" "$sub"
  done
}

for entry in goniod:daemon/man/goniod.8 gonioctl:daemon/man/gonioctl.1 \
             gonio-twin:twin/man/gonio-twin.1 gonio-probe:drivers/man/gonio-probe.1; do
  exe=${entry%%:*} page=$source/${entry#*:}
  name=${page##*/}

  warnings=$(groff -man -ww -z "$page" 2>&1) || fail "$name: groff failed"
  [[ -z $warnings ]] || fail "$name: groff warnings:"$'\n'"$warnings"

  th=$(grep -m1 '^\.TH ' "$page")
  want_th="^\.TH ${exe^^} ${name##*.} [^ ]+ \"gonio $version\" "
  [[ $th =~ $want_th ]] || fail "$name: title line '$th' does not carry 'gonio $version'"

  # The page as text, without roff escapes for hyphens and fonts.
  text=$(sed -e 's/\\-/-/g' -e 's/\\f[BIRP]//g' -e 's/\\&//g' -e 's/\\c//g' "$page")
  for word in $(help_words "$root$bindir/$exe" | sort -u); do
    [[ $word == --help || $word == -h ]] && continue
    [[ $word == !* ]] && { fail "${word#!} --help failed"; continue; }
    grep -qwF -- "$word" <<<"$text" || fail "$name does not document '$word' ($exe --help lists it)"
  done
done

finish
