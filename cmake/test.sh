#!/usr/bin/env bash
# The whole default test suite, as .ci/run runs it (README "Two commands"):
#  1. build/ (Release, g++): every test but the `slow` and `stress` labels, with the Vulkan
#     validation layer on (BASALT_VALIDATION=1 in each test's environment);
#  2. build-san/ (clang, ASan + UBSan with float-cast-overflow, -DBASALT_SANITIZE=ON): the CPU
#     suite and the fuzz regression inputs, less four convergence studies (thousands of
#     renders through code the rest of the suite covers: 5 of the 9 sanitized minutes);
#  3. a short libFuzzer pass over each harness (tools/fuzz.sh with BASALT_FUZZ_RUNS inputs from
#     seed 1, the same inputs on every run: 20000 for the scene and PLY harnesses, a few
#     seconds each, and 5000 for the image readers, whose 20000 took 6 minutes on a 2-core
#     machine), its crashes failing the run. Longer, timed runs that look for new finds: tools/fuzz.sh 600.
# Slow and stress tests: ctest --test-dir build -L slow (or -L stress; docs/hard-cases.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash cmake/setup.sh all
ctest --test-dir build --output-on-failure -j2 -LE 'slow|stress'
CC=clang CXX=clang++ cmake -S . -B build-san -DBASALT_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g" \
  >/dev/null
cmake --build build-san -j"$(nproc)"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-san --output-on-failure -j2 -LE 'slow|stress' \
  -E '^(PathKnobs\.|Sampler\.LowDiscrepancySamplersConverge|LayeredReference\.AnalogWalk)'
BASALT_FUZZ_RUNS=${BASALT_FUZZ_RUNS:-20000} bash tools/fuzz.sh 0 scene ply
BASALT_FUZZ_RUNS=${BASALT_FUZZ_RUNS_IMAGE:-5000} bash tools/fuzz.sh 0 image
