#!/usr/bin/env bash
# Builds the libFuzzer targets in the sanitized clang tree build-asan (.ci/build-sanitized: ASan +
# UBSan + coverage) and runs each for a bounded time on a seed corpus written by code. A crash, a
# sanitizer report, an allocation over the malloc limit or a slow input fails the run; its
# reproducer is left in build-asan/findings/<target>/ (replay: build-asan/tests/fuzz/<target> <file>).
# Environment: FUZZ_SECONDS (per target, default 60), FUZZ_RUNS, FUZZ_JOBS (build parallelism).
# A fixed seed and execution count: every run tries the same inputs, so a finding reproduces and CI
# does not fail by chance on one run and pass on the next (FUZZ_RUNS=-1 for open-ended fuzzing).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
seconds="${FUZZ_SECONDS:-60}"
build=build-asan
start=$(date +%s)
BUILD_JOBS="${FUZZ_JOBS:-$(nproc)}" bash .ci/build-sanitized fuzz_targets
echo "fuzz build: $(( $(date +%s) - start )) s"

seeds="$build/seeds"
rm -rf "$seeds"
"$build/tests/fuzz/fuzz_make_seeds" . "$seeds"
status=0
# target:seed folder:executions:slow-input seconds (FUZZ_SECONDS caps a slow machine). GAP's
# limit is higher: validating a shape seen for the first time (Property 2, gap/validator.hpp)
# takes up to 10 s under ASan + UBSan + coverage here (70 ms in Release).
for t in mesh_load:mesh:20000:10 gap_request:gap:15000:60 cbf_request:cbf:250000:10; do
  timeout="${t##*:}"
  t="${t%:*}"
  runs="${FUZZ_RUNS:-${t##*:}}"
  t="${t%:*}"
  target="fuzz_${t%%:*}"
  corpus="$build/corpus/${t%%:*}"
  findings="$build/findings/$target"
  mkdir -p "$corpus" "$findings"
  cp -n "$seeds/${t##*:}"/* "$corpus"/
  # Inputs that found defects stay in the corpus (run first): they fail until the defect is fixed.
  if [ -d "tests/fuzz/regressions/${t##*:}" ]; then cp -n "tests/fuzz/regressions/${t##*:}"/* "$corpus"/; fi
  echo "== $target: ${seconds} s"
  # -malloc_limit_mb: one allocation over 2 GB (a declared count trusted) is a finding.
  set +e
  # Leaks: the server tests' suppressions (assimp's own leak when a malformed file makes it throw).
  UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1" ASAN_OPTIONS="detect_leaks=1" \
    LSAN_OPTIONS="suppressions=$PWD/tests/server/lsan.supp" \
    "$build/tests/fuzz/$target" -seed=1 -runs="$runs" -max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb=3072 -malloc_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$findings/" "$corpus" >"$build/$target.log" 2>&1
  rc=$?
  set -e
  grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb|SUMMARY|==[0-9]+==ERROR|Test unit written|artifact_prefix)" \
    "$build/$target.log" || true
  if [ "$rc" != 0 ]; then
    echo "!! $target: finding, exit $rc (reproducer in $findings, log $build/$target.log)"
    status=1
  fi
done
exit $status
