#!/bin/sh
# Installs GPG, the antipodal grasp-pose generator of GPD (PyPI grasp-pose-generator 1.0.1), the peer
# of bench/gpg_peer.py, against Debian's PCL. Its setup.py asks for a vcpkg toolchain file and passes
# "-A x64", which Makefile and Ninja generators reject; a two-line toolchain file that clears the
# platform stands in for vcpkg (PCL, Boost and Eigen are found by CMake's own search). About 1 min of
# apt (1.3 GB on disk) and 2 min of build on 2 cores. A benchmark peer only: the library does not use it.
set -eu
export DEBIAN_FRONTEND=noninteractive
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
$SUDO apt-get install -y --no-install-recommends libpcl-dev libeigen3-dev libboost-thread-dev g++
PYTHON=${PYTHON:-python3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/toolchain.cmake" <<'TC'
unset(CMAKE_GENERATOR_PLATFORM CACHE)
set(CMAKE_GENERATOR_PLATFORM "")
TC
VCPKG_TOOLCHAIN_FILE="$tmp/toolchain.cmake" CMAKE_BUILD_PARALLEL_LEVEL="$(nproc)" \
  "$PYTHON" -m pip install --no-cache-dir --no-binary grasp-pose-generator "grasp-pose-generator==1.0.1" "cmake>=3.20"
"$PYTHON" -c "import grasp_pose_generator"
