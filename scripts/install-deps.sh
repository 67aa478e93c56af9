#!/usr/bin/env bash
# Installs every Debian 12 package ringsim needs to build, test and plot.
# Run as root (or through sudo). Idempotent.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  build-essential cmake git pkg-config ca-certificates \
  libopenmpi-dev openmpi-bin \
  libeigen3-dev libfcl-dev \
  libhdf5-openmpi-dev hdf5-tools \
  libsundials-dev \
  libgtest-dev libbenchmark-dev \
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev \
  libboost-math-dev librandom123-dev \
  python3-numpy python3-scipy python3-h5py python3-pandas python3-matplotlib \
  hyperfine \
  libbullet-dev
