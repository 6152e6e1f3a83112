#!/usr/bin/env bash
# System packages libimap needs to build and test on Debian (run as root; idempotent).
set -euo pipefail
PKGS="libclang-dev patchelf cmake unzip pkg-config valgrind python3-pip"
missing=""
for p in $PKGS; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
if [ -n "$missing" ]; then
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing
fi
