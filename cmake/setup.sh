#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages), configures and builds basalt into build/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash cmake/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
