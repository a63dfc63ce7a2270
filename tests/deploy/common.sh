# Shared by the deployment tests (sourced): failures reported one by one before the test
# exits, and the install layout that CMake writes (layout.sh in the test build dir).
set -euo pipefail

failures=0
fail() {
  echo "FAIL: $*" >&2
  failures=$((failures + 1))
}
finish() {
  if ((failures > 0)); then
    echo "$failures check(s) failed" >&2
    exit 1
  fi
  echo "ok"
}
skip() {  # ctest counts exit code 77 as skipped (SKIP_RETURN_CODE)
  echo "SKIP: $*"
  exit 77
}

# shellcheck source=/dev/null
source "${GONIO_DEPLOY_LAYOUT:?set by ctest}"
