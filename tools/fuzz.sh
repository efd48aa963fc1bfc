#!/usr/bin/env bash
# Runs basalt's libFuzzer harnesses (tests/fuzz: the scene parser with table building, the PLY
# reader, the image readers) for SECONDS each, on the sanitizer build (build-san, configured
# and built if needed). Seed corpora come from scenes/, tests/data and scenes/data, with the
# dictionaries of tests/fuzz. A crash, sanitizer report, timeout or out-of-memory fails the run
# and leaves the input in build-san/fuzz-artifacts/: copy it to tests/fuzz/regressions/NAME/ and
# fix the cause (ctest replays those inputs in both builds).
# Usage: tools/fuzz.sh [SECONDS per harness, default 300] [harness names, default all]
# With BASALT_FUZZ_RUNS=N each harness instead runs exactly N inputs from random seed 1 and
# the seed corpus alone: the same inputs on every machine (what CI runs, so that a failure is
# a regression, not a new find of that day; finds come from timed runs).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-300}
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(scene ply image)
B=build-san
if [ ! -f $B/CMakeCache.txt ]; then
  CC=clang CXX=clang++ cmake -S . -B $B -DBASALT_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" >/dev/null
fi
cmake --build $B -j"$(nproc)" --target $(printf 'basalt_fuzz_%s ' "${harnesses[@]}")

# Seed corpora (rebuilt each run; what the fuzzer adds goes to $B/fuzz-corpus/NAME-new).
seed() {  # harness, then files
  local dir=$B/fuzz-corpus/$1; shift
  rm -rf "$dir" && mkdir -p "$dir" "$B/fuzz-corpus/$(basename "$dir")-new"
  [ -z "${BASALT_FUZZ_RUNS:-}" ] || rm -rf "$B/fuzz-corpus/$(basename "$dir")-new"/*
  for f in "$@"; do [ -f "$f" ] && cp "$f" "$dir/$(echo "$f" | tr / _)"; done
  # A regression input is a seed too.
  cp tests/fuzz/regressions/"$(basename "$dir")"/* "$dir"/ 2>/dev/null || true
}
# Scene seeds without meshes or image files: each input is parsed and built whole, and the
# 269k-triangle Igea or a displaced mesh would take seconds per run under the sanitizers.
seed scene $(grep -L -E 'plymesh|"string filename"|Include|Import' scenes/*.pbrt) \
  $(find tests/data -name '*.pbrt')
seed ply scenes/data/*.ply
# The image harness reads one selector byte (the file type: 0 png, 1 exr, 2 pfm) before the file.
seed image
for f in scenes/data/*.png scenes/data/*.exr; do
  case $f in *.png) sel='\000' ;; *.exr) sel='\001' ;; esac
  { printf "$sel"; head -c 65536 "$f"; } > $B/fuzz-corpus/image/$(basename "$f")
done
printf '\002PF\n2 2\n-1.0\n' > $B/fuzz-corpus/image/tiny.pfm && head -c 48 /dev/urandom >> $B/fuzz-corpus/image/tiny.pfm

mkdir -p $B/fuzz-artifacts
status=0
for h in "${harnesses[@]}"; do
  if [ -n "${BASALT_FUZZ_RUNS:-}" ]; then
    budget=(-runs="$BASALT_FUZZ_RUNS" -seed=1); echo "== fuzzing $h: $BASALT_FUZZ_RUNS inputs, seed 1"
  else
    budget=(-max_total_time="$seconds"); echo "== fuzzing $h for $seconds s"
  fi
  # -rss_limit_mb: the harnesses use lavapipe's 128 MiB table limit, far below it.
  if ! ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
      $B/basalt_fuzz_$h "${budget[@]}" -timeout=20 -rss_limit_mb=2560 \
        -dict=tests/fuzz/$h.dict -artifact_prefix=$B/fuzz-artifacts/$h- -print_final_stats=1 \
        $B/fuzz-corpus/$h-new $B/fuzz-corpus/$h 2>$B/fuzz-$h.log; then
    echo "FUZZ FAILURE in $h: see $B/fuzz-$h.log and $B/fuzz-artifacts/"; tail -40 $B/fuzz-$h.log
    status=1
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" $B/fuzz-$h.log | sed "s/^/  $h /"
done
exit $status
