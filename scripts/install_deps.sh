#!/usr/bin/env bash
# Installs what pairgrasp needs to build and test: C++ libraries from Debian (clang and its fuzzer
# runtime for the libFuzzer harnesses, chromium for the viewer's browser test, ccache so that the
# wheel's build reuses the Release build's objects), Python packages from
# PyPI (atheris for the Python harness, viser for the viewer, Ray for `pairgrasp batch --engine ray`).
# Safe to run again; uses sudo only when not root.
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

DEBIAN_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libfcl-dev libccd-dev libassimp-dev liburdfdom-dev
  libgtest-dev libbenchmark-dev nlohmann-json3-dev libqhull-dev
  clang libclang-rt-14-dev
  chromium
  ccache
)

missing=()
for p in "${DEBIAN_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# cmake and ninja may come from PyPI instead (a newer cmake on PATH is fine).
if command -v cmake >/dev/null 2>&1; then missing=("${missing[@]/cmake}"); fi
if command -v ninja >/dev/null 2>&1; then missing=("${missing[@]/ninja-build}"); fi
pkgs=()
for p in "${missing[@]}"; do [ -n "$p" ] && pkgs+=("$p"); done
if [ "${#pkgs[@]}" -gt 0 ]; then
  echo "install_deps: apt-get install ${pkgs[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null
fi

PYTHON="${PYTHON:-python3}"
"$PYTHON" -m pip install -q --disable-pip-version-check \
  "scikit-build-core>=0.10" "pybind11>=2.12" "numpy>=1.24" "scipy>=1.10" "matplotlib>=3.6" "fast-simplification>=0.1.7" "pytest>=7" "pytest-xdist>=3" "trimesh>=4" "rtree>=1.0" "libigl>=2.5" "pybullet>=3.2" \
  "mujoco>=4.0" "coacd>=1.0.14" \
  "atheris>=2.3" "viser>=1.0" "ray>=2.9"
# The Shadow hand's MJCF and meshes for the hand-import tests and benchmarks: the package's data
# only (its Python side needs gymnasium, which nothing here uses).
"$PYTHON" -m pip install -q --disable-pip-version-check --no-deps "gymnasium-robotics>=1.2"
echo "install_deps: done"
