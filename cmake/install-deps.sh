#!/usr/bin/env bash
# Installs basalt's build and test dependencies from Debian 12 packages, only those missing.
# Idempotent: a second run with everything present does nothing and needs no network.
# Usage: install-deps.sh [bench]
set -euo pipefail
pkgs=(
  build-essential cmake pkg-config
  libvulkan-dev vulkan-tools mesa-vulkan-drivers vulkan-validationlayers
  glslang-tools spirv-tools libglm-dev libopenexr-dev libpng-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev
  python3-matplotlib
  clang libclang-rt-14-dev
)
# `install-deps.sh bench`: also Embree 3, the benchmark's traversal peer (never linked into
# the renderer or the CPU reference).
if [ "${1:-}" = bench ]; then pkgs+=(libembree-dev); fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then exit 0; fi
echo "basalt: installing ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
