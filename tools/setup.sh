#!/usr/bin/env bash
# Installs, with apt-get, whatever the project needs that is missing. Idempotent: prints nothing
# and touches nothing when every package is already installed.
set -euo pipefail

packages=(
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  glslang-tools glslang-dev
  libglm-dev libglfw3-dev libopenmesh-dev libimgui-dev libstb-dev libembree-dev
  nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox jq
  xvfb xauth cmake ninja-build g++ pkg-config
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup.sh: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi

echo "setup.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup.sh: done"
