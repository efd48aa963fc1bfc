#!/usr/bin/env bash
# Installs basalt's build and test dependencies from Debian 12 packages, only those missing.
# Idempotent: a second run with everything present does nothing and needs no network.
# Usage: [BASALT_MESA=stable|backports] install-deps.sh [bench]
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
# BASALT_MESA=backports: lavapipe from bookworm-backports (Mesa 25) instead of Debian 12's own
# (Mesa 22.3): the same images, renders 1.2-2.6x faster, pipelines about 1.8x slower to compile
# cold (docs/performance.md, twelfth session). Installed system-wide, so it is asked for, never
# assumed; BASALT_MESA=stable (the default) keeps whichever Mesa the machine has.
mesa="${BASALT_MESA:-stable}"
case "$mesa" in
  stable | backports) ;;
  *) echo "basalt: BASALT_MESA must be stable or backports, not '$mesa'" >&2; exit 2 ;;
esac
backports_needed=false
if [ "$mesa" = backports ]; then
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  if [ -z "$v" ] || dpkg --compare-versions "$v" lt 25; then backports_needed=true; fi
  codename=$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")
  if [ "$backports_needed" = true ] && [ "$codename" != bookworm ]; then
    echo "basalt: BASALT_MESA=backports is for Debian 12 (bookworm), this is '${codename:-unknown}'" >&2
    exit 2
  fi
fi
if [ ${#missing[@]} -eq 0 ] && [ "$backports_needed" = false ]; then exit 0; fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if [ "$backports_needed" = true ] &&
  ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  echo "basalt: adding bookworm-backports to apt's sources" >&2
  printf '%s\n' 'Types: deb' 'URIs: http://deb.debian.org/debian' 'Suites: bookworm-backports' \
    'Components: main' 'Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg' |
    $sudo tee /etc/apt/sources.list.d/basalt-bookworm-backports.sources >/dev/null
fi
$sudo apt-get update -qq
if [ ${#missing[@]} -gt 0 ]; then
  echo "basalt: installing ${missing[*]}" >&2
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
if [ "$backports_needed" = true ]; then
  echo "basalt: installing mesa-vulkan-drivers from bookworm-backports" >&2
  $sudo apt-get install -y -qq --no-install-recommends -t bookworm-backports \
    mesa-vulkan-drivers >/dev/null
  v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)
  if dpkg --compare-versions "$v" lt 25; then
    echo "basalt: bookworm-backports gave mesa-vulkan-drivers $v, not 25 or later" >&2
    exit 1
  fi
fi
