#!/usr/bin/env bash
# Installs the Debian 12 packages peha needs, skipping those already present.
# Uses sudo when not root. Safe to run repeatedly.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev          # linear algebra (models, GP)
  libceres-dev           # Levenberg-Marquardt (calibration)
  libmujoco-dev          # rigid-body simulation of the plant
  libqhull-dev           # Debian's mujoco CMake config lists /usr/include/libqhull_r as an include dir
  libyaml-cpp-dev        # configuration files
  libssl-dev             # SHA-256 of calibration data files (libcrypto)
  libsodium-dev          # MFB link: packet MAC (keyed BLAKE2b), random session ids and arm tokens
  libcli11-dev           # command line
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  pybind11-dev python3-pytest   # the Python module peha (python/) and its tests under ctest (python.pytest)
  ffmpeg                 # peha run --video: H.264 encoding of the rendered frames (ffmpeg, ffprobe in the tests)
  libegl-dev libgl1-mesa-dri   # offscreen OpenGL for MuJoCo's renderer: EGL on Mesa's surfaceless platform (llvmpipe)
  libopengl-dev          # libOpenGL.so (GLVND): CMake's FindOpenGL requires it; nothing else pulls it in without recommends
  libglfw3-dev xvfb xauth      # fallback: a hidden GLFW window, on an Xvfb that peha starts when DISPLAY is unset
  clang-14 libclang-rt-14-dev   # libFuzzer (+ ASan/UBSan) for the MFB packet parser's fuzz target
  python3-numpy python3-scipy python3-matplotlib python3-sklearn  # tools/ on /usr/bin/python3
  gcc-arm-none-eabi picolibc-arm-none-eabi qemu-system-arm  # the board core (firmware/) built for a Cortex-M7 and tested on QEMU
  python3-pandas         # the test that peha's CSVs open unmodified in pandas.read_csv (runtime.logs_open_unmodified)
  python3-venv python3-setuptools python3-wheel   # pip install ./python into a virtual environment, offline (python.package; pip builds a wheel)
  python3-yaml           # tools/plot_identification.py reads an identification's YAML
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# The board core's Cortex-M tests take their MAC from the BLAKE2 reference code (libb2's source).
fetch_sources() { "$(dirname "$0")/fetch-libb2.sh"; }

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  fetch_sources
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fetch_sources
