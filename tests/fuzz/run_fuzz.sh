#!/bin/sh
# run_fuzz.sh BINARY CORPUS WORK SECONDS — fuzzes one libFuzzer target for SECONDS on a
# copy of its seed corpus in WORK/corpus (the source tree is never written), leaving any
# finding in WORK/artifacts/. The exit status is libFuzzer's: non-zero on a finding. A
# finding becomes a regression seed once fixed: copy it into tests/fuzz/corpus/<name>/.
set -eu
bin=$1 corpus=$2 work=$3 seconds=$4
rm -rf "$work"
mkdir -p "$work/corpus" "$work/artifacts"
cp -R "$corpus/." "$work/corpus/"
exec "$bin" -max_total_time="$seconds" -timeout=25 -rss_limit_mb=2560 -print_final_stats=1 \
  -artifact_prefix="$work/artifacts/" "$work/corpus"
