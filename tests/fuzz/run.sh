#!/bin/sh
# Runs one libFuzzer target briefly: run.sh FUZZER SEED_DIR SECONDS [DICTIONARY].
# New inputs go to a temporary corpus (first, so the source tree is never written); the
# committed seeds are read from SEED_DIR. On a crash, leak, UB report or timeout the temporary
# folder is kept and the saved input is named; otherwise it is removed.
set -u
fuzzer=$1
seeds=$2
seconds=$3
if [ $# -ge 4 ]; then set -- "-dict=$4"; else set --; fi
tmp=$(mktemp -d "${TMPDIR:-/tmp}/strandcast-fuzz.XXXXXX") || exit 1
mkdir "$tmp/corpus"
"$fuzzer" "$@" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
  -artifact_prefix="$tmp/" "$tmp/corpus" "$seeds"
rc=$?
if [ "$rc" -ne 0 ]; then
  for f in "$tmp"/crash-* "$tmp"/leak-* "$tmp"/timeout-* "$tmp"/oom-* "$tmp"/slow-unit-*; do
    [ -e "$f" ] && echo "fuzz: failing input saved as $f (reproduce: $fuzzer $f)"
  done
  echo "fuzz: $fuzzer failed (exit $rc); corpus and artifacts kept in $tmp"
  exit "$rc"
fi
rm -rf "$tmp"
