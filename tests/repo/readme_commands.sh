#!/usr/bin/env bash
# The README has exactly two set-up commands, marked <!-- main-command --> and
# <!-- test-command -->, and .ci/run executes the test command verbatim.
set -euo pipefail
root=$1
readme=$root/README.md
extract() { awk -v tag="<!-- $1 -->" '$0==tag{getline; getline; print; exit}' "$readme"; }
main=$(extract main-command)
test=$(extract test-command)
[[ -n $main ]] || { echo "README: no main command after <!-- main-command -->"; exit 1; }
[[ -n $test ]] || { echo "README: no test command after <!-- test-command -->"; exit 1; }
[[ $(grep -c '^<!-- \(main\|test\)-command -->$' "$readme") == 2 ]] ||
  { echo "README: expected exactly two set-up command markers"; exit 1; }
# .ci/run must take its command from the README through the same extraction.
grep -q 'test-command' "$root/.ci/run" || { echo ".ci/run does not read the README's test command"; exit 1; }
got=$(bash "$root/.ci/run" --print-command)
[[ $got == "$test" ]] || { printf '.ci/run would run:\n  %s\nREADME says:\n  %s\n' "$got" "$test"; exit 1; }
echo "ok: $test"
