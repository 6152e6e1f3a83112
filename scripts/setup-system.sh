#!/usr/bin/env bash
# System packages libimap needs to build and test on Debian (as root, or through sudo;
# idempotent): libclang for bindgen, patchelf for the Embree libraries, cmake, unzip,
# pkg-config, abigail-tools and python3 for the ABI check, assimp-testmodels (the
# third-party model corpus the command's corpus test reads), Open MPI (libopenmpi-dev and
# openmpi-bin: the MPI example ctest runs with mpirun -np 2), MinGW-w64 and Wine (the
# Windows build, cross-compiled and run under Wine: scripts/test-windows.sh), clang and
# lld (a program of the MSVC ABI linked by lld-link against the package's imap.lib), and pip (to
# fetch the pinned Embree wheels) when the machine has none.
set -euo pipefail
PKGS="libclang-dev patchelf cmake unzip pkg-config fonts-dejavu-core abigail-tools assimp-testmodels libopenmpi-dev openmpi-bin gcc-mingw-w64-x86-64 g++-mingw-w64-x86-64 wine wine64 clang-14 lld-14"
command -v python3 >/dev/null || PKGS="$PKGS python3"
command -v pip3 >/dev/null || PKGS="$PKGS python3-pip"
missing=""
for p in $PKGS; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
if [ -n "$missing" ]; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
fi
