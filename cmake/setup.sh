#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds basalt into build/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash cmake/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
# ctest starts the longest tests first when it knows their times; a fresh build directory does
# not, and on 2 cores the suite then ends with long GPU tests running alone (31 minutes instead
# of about 25). cmake/ctest-cost-data.txt holds measured times (a clean-clone run); ctest keeps
# its own file up to date after that.
if [ ! -f build/Testing/Temporary/CTestCostData.txt ]; then
  mkdir -p build/Testing/Temporary
  cp cmake/ctest-cost-data.txt build/Testing/Temporary/CTestCostData.txt
fi
