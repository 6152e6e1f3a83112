#!/usr/bin/env bash
# Checks the C ABI of the built libimap.so against the committed baseline in abi/:
#   1. abidiff (Debian abigail-tools) of the library's exported functions: a removed or
#      changed symbol fails (new functions are additions);
#   2. the layout of every type imap.h declares, measured by a program compiled from the
#      header (scripts/abi_layout.py): within an ABI epoch (the soname, libimap.so.0.N
#      while the major version is 0), fields keep their offsets, sizes and types, structs
#      only grow by appended fields, enumerators and macros keep their values, functions
#      their prototypes (but a function that returned nothing may come to return a status:
#      callers built against the old header ignore it).
# An incompatible change fails unless it comes with a new ABI epoch (a version bump) and a
# new baseline, recorded on purpose with:   scripts/abi-check.sh --update
#
# Usage: scripts/abi-check.sh [--update] [LIBRARY]   (default: target/release/libimap.so)
set -euo pipefail
cd "$(dirname "$0")/.."
UPDATE=0
if [ "${1:-}" = "--update" ]; then UPDATE=1; shift; fi
LIB=${1:-target/release/libimap.so}
for tool in abidw abidiff python3 cc readelf; do
  command -v "$tool" >/dev/null || { echo "abi-check: missing '$tool' (scripts/setup-system.sh installs it)" >&2; exit 1; }
done
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

SONAME=$(readelf -d "$LIB" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
[ -n "$SONAME" ] || { echo "abi-check: $LIB has no SONAME" >&2; exit 1; }

# 1. The exported functions, as abidiff sees them.
abidw --no-corpus-path --no-show-locs "$LIB" > "$TMP/libimap.abi"

# 2. The header's types, measured.
python3 scripts/abi_layout.py probe include/imap.h > "$TMP/probe.c"
cc -std=c11 -Wall -Werror -Iinclude "$TMP/probe.c" -L"$(dirname "$LIB")" -l:"$(basename "$LIB")" \
  -Wl,-rpath,"$(cd "$(dirname "$LIB")" && pwd)" ${EMBREE_DIR:+-Wl,-rpath,$EMBREE_DIR} -o "$TMP/probe"
{ echo "soname libimap $SONAME"; "$TMP/probe"; } > "$TMP/layout.txt"

if [ "$UPDATE" = 1 ]; then
  mkdir -p abi
  cp "$TMP/libimap.abi" abi/libimap.abi
  cp "$TMP/layout.txt" abi/layout.txt
  echo "abi-check: baseline recorded for $SONAME in abi/ (commit it)"
  exit 0
fi

status=0
set +e
abidiff --no-added-syms abi/libimap.abi "$TMP/libimap.abi" > "$TMP/abidiff.txt"
code=$?
set -e
if [ $((code & 8)) -ne 0 ] || [ $((code & 1)) -ne 0 ]; then
  echo "abi-check: abidiff found an incompatible change of the exported functions (exit $code):"
  cat "$TMP/abidiff.txt"
  status=1
fi
python3 scripts/abi_layout.py compare abi/layout.txt "$TMP/layout.txt" || status=1
if [ "$status" = 0 ]; then
  echo "abi-check: $SONAME is compatible with the baseline ($(grep -c '^fn ' "$TMP/layout.txt") functions, $(grep -c '^struct ' "$TMP/layout.txt") structs)"
fi
exit $status
