#!/usr/bin/env bash
# Provision Embree 4 for building and running libimap.
#
# Prints the directory holding libembree4.so (to be used as EMBREE_DIR) on its last line.
# - If the system already has Embree 4 (Debian trixie+, Ubuntu 24.04+), it is used as is.
# - Otherwise (Debian bookworm) the libraries are taken from the pinned PyPI wheel
#   embreex==4.4.0.post1 (manylinux_2_28), its hash checked, and installed into
#   deps/embree4/lib of the project (ignored by git), with their SONAMEs fixed.
# The step is idempotent: it does nothing when the libraries are already in place.
# Needs: pip, unzip, patchelf (installed by scripts/setup-system.sh).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
WHEEL_VERSION=4.4.0.post1
WHEEL_SHA256=2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f
L="$ROOT/deps/embree4/lib"

log() { echo "setup-embree: $*" >&2; }

# 1. A system Embree 4 wins.
for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/lib /usr/local/lib; do
  if [ -e "$d/libembree4.so" ] && [ "${IMAP_FORCE_WHEEL_EMBREE:-0}" != 1 ]; then
    log "using system Embree 4 in $d"
    echo "$d"
    exit 0
  fi
done

# 2. Already provisioned?
if [ -f "$L/libembree4.so.4" ] && [ -f "$L/libtbb.so.12" ] && [ -L "$L/libembree4.so" ] \
   && [ -f "$L/.complete" ]; then
  log "already provisioned in $L"
  echo "$L"
  exit 0
fi

# 3. Fetch the pinned wheel and extract the two libraries.
for tool in pip3 unzip patchelf sha256sum; do
  command -v "$tool" >/dev/null || { log "missing tool '$tool' (run scripts/setup-system.sh as root)"; exit 1; }
done
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
log "downloading embreex==$WHEEL_VERSION from PyPI"
pip3 download --quiet --no-deps --only-binary=:all: --platform manylinux_2_28_x86_64 \
  --python-version 3.11 "embreex==$WHEEL_VERSION" -d "$TMP" >&2
WHL=$(ls "$TMP"/embreex-*.whl)
echo "$WHEEL_SHA256  $WHL" | sha256sum -c --quiet - >&2 || { log "wheel hash mismatch"; exit 1; }
unzip -q "$WHL" 'embreex.libs/*' -d "$TMP/x"

rm -rf "$L"; mkdir -p "$L"
cp "$TMP"/x/embreex.libs/libembree4-*.so.4 "$L/libembree4.so.4"
cp "$TMP"/x/embreex.libs/libtbb-*.so.12 "$L/libtbb.so.12"
chmod 0755 "$L"/*.so.*
# Separate patchelf calls: bookworm's patchelf 0.14 corrupts the file when combined.
patchelf --set-soname libembree4.so.4 "$L/libembree4.so.4"
patchelf --set-soname libtbb.so.12 "$L/libtbb.so.12"
OLD_TBB=$(patchelf --print-needed "$L/libembree4.so.4" | grep tbb)
patchelf --replace-needed "$OLD_TBB" libtbb.so.12 "$L/libembree4.so.4"
patchelf --set-rpath '$ORIGIN' "$L/libembree4.so.4"
ln -sf libembree4.so.4 "$L/libembree4.so"
touch "$L/.complete"
log "installed Embree 4.4.0 into $L"
echo "$L"
