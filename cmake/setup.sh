#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures build/ and builds the renderer
# only (build/basalt): the README's render command. `cmake/setup.sh all` builds every target
# of `all` (the tests too), as cmake/test.sh does.
set -euo pipefail
cd "$(dirname "$0")/.."
bash cmake/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
if [ "${1:-}" = all ]; then
  cmake --build build -j"$(nproc)"
else
  cmake --build build -j"$(nproc)" --target basalt
fi
