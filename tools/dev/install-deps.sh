#!/usr/bin/env bash
# Installs the Debian packages brdf-service builds against, if any is missing. Idempotent and quiet
# when everything is present; uses sudo when not root; never prompts (CI has no terminal).
#   tools/dev/install-deps.sh          the packages needed to build and test
#   tools/dev/install-deps.sh --fuzz   also the optional fuzzing toolchain (optional_fuzz below)
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers clinfo
  libpng-dev libopenexr-dev openexr libdeflate-dev
  libopenimageio-dev openimageio-tools
  nlohmann-json3-dev libcli11-dev
  libopenblas-dev liblapacke-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  python3 python3-numpy
)

# Optional, not installed by default: clang with libFuzzer for tools/dev/fuzz.sh (tests/fuzz,
# -DBRDF_FUZZ=ON). Add them with: tools/dev/install-deps.sh --fuzz
optional_fuzz=(clang-14 libclang-rt-14-dev)
for arg in "$@"; do
  case "$arg" in
    --fuzz) packages+=("${optional_fuzz[@]}") ;;
    *) echo "usage: $0 [--fuzz]" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: not root and no sudo; install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -q
$sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
