#!/usr/bin/env bash
# The Windows build (issue 35), cross-built here and run under Wine (docs/windows.md):
# scripts/build-windows.sh makes the package; c_tests and c_examples are configured by
# CMake with the MinGW toolchain (cmake/mingw-w64-wine.cmake) against the package and run by
# ctest under Wine; a program of the MSVC ABI is linked by lld-link against imap.lib; then
# imap.exe runs its validation, the demo, one model of each format, a luminaire file, a sky
# image, a state and shards, each map compared with the Linux command's for the same seed
# and settings to 1e-12, from paths with a space and a non-ASCII letter; and bad paths and
# Windows device names get clear errors. Needs what build-windows.sh needs, Wine, clang and
# lld (scripts/setup-system.sh installs them; the Rust target is added here).
#
# Wine 8 (Debian bookworm) lacks bcryptprimitives.dll, which Rust's standard library
# imports for ProcessPrng (Windows 10 and later have it): the test folder gets a stand-in
# built here from RtlGenRandom. It is not part of the package.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
rustup target list --installed 2>/dev/null | grep -qx x86_64-pc-windows-gnu \
  || rustup target add x86_64-pc-windows-gnu >&2
PKG=$(scripts/build-windows.sh | tail -1)
T=$(mktemp -d)
# IMAP_KEEP_WINDOWS_TEST=1 keeps the folder (the Wine prefix, builds and outputs) to look into.
# Wine's server is stopped first: it writes to its prefix in T until it exits.
[ "${IMAP_KEEP_WINDOWS_TEST:-0}" = 1 ] && echo "windows test folder: $T" >&2 \
  || trap 'WINEPREFIX="$T/wine" wineserver -k >/dev/null 2>&1; WINEPREFIX="$T/wine" wineserver -w >/dev/null 2>&1; rm -rf "$T"' EXIT
CC=x86_64-w64-mingw32-gcc
CXX=x86_64-w64-mingw32-g++
INC="-I$PKG/include"

echo "== the header as C++17 under MinGW (as C89 -pedantic: the c89_header example below)"
$CXX -std=c++17 -Wall -Wextra -Werror $INC -x c++ -fsyntax-only - <<<'#include "imap.hpp"
int main() { return 0; }'

# Wine 8 lacks bcryptprimitives.dll (see above): a stand-in, on WINEPATH beside the package.
mkdir -p "$T/shim"
printf 'LIBRARY bcryptprimitives\nEXPORTS\nProcessPrng\n' > "$T/shim/bcp.def"
cat > "$T/shim/bcp.c" <<'C'
#include <windows.h>
#define SystemFunction036 NTAPI SystemFunction036
#include <ntsecapi.h>
#undef SystemFunction036
BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len) {
    while (len > 0) {
        ULONG n = len > 0x7fffffff ? 0x7fffffff : (ULONG)len;
        if (!RtlGenRandom(data, n)) return FALSE;
        data += n, len -= n;
    }
    return TRUE;
}
C
$CC -O2 -shared -o "$T/shim/bcryptprimitives.dll" "$T/shim/bcp.c" "$T/shim/bcp.def" -ladvapi32

export WINEPREFIX="$T/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
# One wineserver for the whole test, kept running between programs (left alone it exits
# a few seconds after the last one, and a program started just then loses its connection).
mkdir -p "$WINEPREFIX"
wineserver -p
wine wineboot --init >/dev/null 2>&1 || true
# Windows finds the package's DLLs (imap, Embree, TBB) as a user's PATH would give them.
WINEPATH="$(winepath -w "$PKG/bin");$(winepath -w "$T/shim")"
export WINEPATH

echo "== C tests and examples: CMake (MinGW toolchain, find_package(imap) from the package), ctest under Wine"
# The imported target imap::imap of the package's CMake config, as a MinGW consumer sees
# it; CMAKE_CROSSCOMPILING_EMULATOR runs every test under Wine. The long physics runs of
# the examples passed on Linux on the same sources; here the quick ones prove the port.
# The fuzzer makes 5 000 of its seeded random calls here (100 000 on Linux): each of its
# contexts starts a thread pool, which under Wine goes through the one wineserver.
for dir in c_tests c_examples; do
  extra=""; [ "$dir" = c_tests ] && extra="-DIMAP_FUZZ_CALLS=5000"
  cmake -S "$dir" -B "$T/$dir" -DCMAKE_TOOLCHAIN_FILE="$ROOT/cmake/mingw-w64-wine.cmake" \
    -DCMAKE_PREFIX_PATH="$PKG" -DCMAKE_BUILD_TYPE=Release $extra >/dev/null
  cmake --build "$T/$dir" -j "$(nproc)" >/dev/null
done
ctest --test-dir "$T/c_tests" --output-on-failure -j "$(nproc)" --timeout 600
ctest --test-dir "$T/c_examples" --output-on-failure -j "$(nproc)" --timeout 600 \
  -E 'luminaire_room|edge_lit_panel|render_cornell_sync|render_cornell_fg'

run() { # run NAME: the program's last line, or its whole output when it fails
  local out rc=0
  out=$(cd "$T" && timeout 600 wine "$1.exe" 2>&1) || rc=$?
  if [ $rc -ne 0 ]; then echo "$out" >&2; echo "$1.exe under Wine: exit $rc" >&2; exit 1; fi
  echo "$1.exe: $(echo "$out" | tr -d '\r' | tail -1)"
}

echo "== the MSVC import library imap.lib"
# A MinGW program linked through imap.lib (GNU ld reads the MSVC import library).
$CC -std=c99 -O2 $INC c_tests/bad_input.c "$PKG/lib/imap.lib" -o "$T/bad_input_msvc_implib.exe"
run bad_input_msvc_implib
# A program of the MSVC ABI (clang --target=x86_64-pc-windows-msvc), linked by lld-link
# against imap.lib as link.exe would, with no C runtime: kernel32 is all it imports
# besides imap.dll (MinGW's kernel32 import library serves lld-link).
LLVM_BIN=$(ls -d /usr/lib/llvm-*/bin 2>/dev/null | sort -V | tail -1)
if [ -x "$LLVM_BIN/clang" ] && [ -x "$LLVM_BIN/lld-link" ]; then
  "$LLVM_BIN/clang" --target=x86_64-pc-windows-msvc -ffreestanding -fno-builtin -mno-stack-arg-probe \
    -O2 -Wall -Wextra -Werror $INC -c c_tests/msvc_abi.c -o "$T/msvc_abi.obj"
  "$LLVM_BIN/lld-link" /nologo /entry:start /subsystem:console /nodefaultlib /out:"$T/msvc_abi.exe" \
    "$T/msvc_abi.obj" "$PKG/lib/imap.lib" /usr/x86_64-w64-mingw32/lib/libkernel32.a
  run msvc_abi
else
  echo "WARNING: no clang and lld-link (Debian: clang-14 lld-14): the MSVC-ABI link of imap.lib is not checked" >&2
fi

echo "== imap.exe under Wine: its version, the analytic validation"
cp "$PKG/bin/imap.exe" "$T/"
(cd "$T" && timeout 600 wine imap.exe --version | tr -d '\r')
(cd "$T" && timeout 600 wine imap.exe validate --photons 200000 | tr -d '\r' | tail -4)

# Every map below is computed by imap.exe under Wine and by the Linux command with the same
# seed and settings on one thread (the same photons, summed in the same order), and the two
# must agree to 1e-12 (scripts/same-map.py). Inputs sit in a folder whose name has a space
# and a non-ASCII letter; imap.exe gets them as Windows paths (backslashes, a drive).
LINUX="$ROOT/target/release/imap"
[ -x "$LINUX" ] || (cd "$ROOT" && cargo build --release -p imap-cli >&2)
# No target error and no time budget: the photon count alone ends each run, as it must
# for two runs to trace the same photons.
ONE="--threads 1 --seed 7 --scheduler classic --target-error 0 --time 0 --quiet"
M="$T/model dir ä"
WM=$(winepath -w "$M")
mkdir -p "$M"
win() { (cd "$T" && timeout 600 wine imap.exe "$@" 2>"$T/wine.err" | tr -d '\r') || { tr -d '\r' < "$T/wine.err" >&2; echo "imap.exe $1 under Wine failed" >&2; exit 1; }; }
same() { python3 "$ROOT/scripts/same-map.py" "$1/irradiance.csv" "$2/irradiance.csv" 1e-12 "$3"; }

echo "== the demo (the Cornell box) under Wine and on Linux"
"$LINUX" demo --out "$T/demo-linux" --photons 200000 $ONE >/dev/null
win demo --out "demo win" --photons 200000 $ONE >/dev/null
same "$T/demo-linux" "$T/demo win" "imap.exe demo"

echo "== one model of each format"
# A room of our own (OBJ with its MTL, and the same room as Radiance scene text), and
# third-party models of Debian's assimp-testmodels (glTF with its .bin and texture, GLB,
# binary PLY, binary STL), each lit by a point light above it that `imap info` places.
printf 'newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n' > "$M/s.mtl"
cat > "$M/s.obj" <<'OBJ'
mtllib s.mtl
o floor
usemtl grey
v 0 0 0
v 4 0 0
v 4 4 0
v 0 4 0
v 2 0 0
v 4 2 0
v 2 4 0
v 0 2 0
v 2 2 0
f 1 5 9 8
f 5 2 6 9
f 9 6 3 7
f 8 9 7 4
o wall
usemtl grey
v 0 4 0
v 4 4 0
v 4 4 3
v 0 4 3
f 10 11 12 13
o lamp
usemtl lamp
v 1.5 1.5 2.5
v 1.5 2.5 2.5
v 2.5 2.5 2.5
v 2.5 1.5 2.5
f 14 15 16 17
OBJ
printf 'up_axis = "z"\n' > "$M/s.toml"
cat > "$M/room ä.rad" <<'RAD'
void plastic grey
0
0
5 0.5 0.5 0.5 0 0
grey polygon floor
0
0
12 0 0 0  4 0 0  4 4 0  0 4 0
grey polygon wall
0
0
12 0 4 0  4 4 0  4 4 3  0 4 3
RAD
A=/usr/share/assimp/models
cp -r "$A/glTF2/BoxTextured-glTF" "$M/gltf"
cp "$A/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb" "$A/PLY/cube_binary.ply" "$A/STL/Spider_binary.stl" "$M/"
for model in "s.obj" "room ä.rad" "gltf/BoxTextured.gltf" "BoxTextured.glb" "cube_binary.ply" "Spider_binary.stl"; do
  cfg="$M/s.toml"
  if [ "$model" != s.obj ]; then
    cfg="$M/$(basename "$model").toml"
    "$LINUX" info "$M/$model" | python3 -c '
import json, sys
b = json.load(sys.stdin)["bounds"]
size = max(max(b[1][i] - b[0][i] for i in range(3)), 1e-3)
c = [0.5 * (b[0][i] + b[1][i]) for i in range(3)]
p = [c[0] + 0.5 * size, b[1][1] + size, c[2] + 0.7 * size]
print("two_sided = true\n[[light]]\nkind = \"point\"\nposition = %r\namount = 1000\nunit = \"lm\"" % p)' > "$cfg"
  fi
  out="$(basename "$model" | tr -c 'A-Za-z0-9\n' _)"
  "$LINUX" run "$M/$model" --config "$cfg" --photons 200000 $ONE --out "$T/linux-$out" >/dev/null 2>&1
  win run "$WM\\${model//\//\\}" --config "$(winepath -w "$cfg")" --photons 200000 $ONE --out "win-$out" >/dev/null
  same "$T/linux-$out" "$T/win-$out" "imap.exe run $model"
done

echo "== a luminaire file, a sky image and a state, from paths with a space and a non-ASCII letter"
cp c_examples/data/downlight.ies "$M/down light ä.ies"
cp tests/data/evalglare_window.hdr "$M/sky ä.hdr"
cat > "$M/lit ä.toml" <<'TOML'
up_axis = "z"
[[luminaire]]
file = "down light ä.ies"
position = [2, 2, 2.9]
aim = [0, 0, -1]
[environment]
file = "sky ä.hdr"
horizontal_illuminance = 2000
TOML
"$LINUX" run "$M/s.obj" --config "$M/lit ä.toml" --photons 200000 $ONE --out "$T/linux-lit" >/dev/null 2>&1
win run "$WM\\s.obj" --config "$WM\\lit ä.toml" --photons 200000 $ONE --out "win lit" \
  --checkpoint "$WM\\state ä.imap" >/dev/null
same "$T/linux-lit" "$T/win lit" "imap.exe run with an IES file and a sky image"
# The state imap.exe wrote, resumed by imap.exe from its non-ASCII path (a finished run:
# the outputs again, the same map).
win resume "$WM\\state ä.imap" --out "win resumed" --quiet >/dev/null
same "$T/linux-lit" "$T/win resumed" "imap.exe resume of its state"
# Two shards traced by imap.exe into states there, merged by imap.exe: the whole run's map.
# (A state names its model by the path it was run with: a Windows state resumes on Windows.)
for k in 0 1; do
  win run "$WM\\s.obj" --config "$WM\\lit ä.toml" --photons 200000 $ONE --shard "$k/2" \
    --checkpoint "$WM\\shard ä $k.imap" >/dev/null
done
win merge "$WM\\shard ä 0.imap" "$WM\\shard ä 1.imap" --out "win merged" >/dev/null
same "$T/linux-lit" "$T/win merged" "imap.exe merge of its two shards"

echo "== reserved names and bad paths: clear errors (exit 2), not crashes"
refused() { # refused WHAT ARGS...: imap.exe exits 2 with an `imap: error` line
  local what=$1 rc=0; shift
  (cd "$T" && timeout 600 wine imap.exe "$@" >/dev/null 2>"$T/refused.err") || rc=$?
  local msg; msg=$(tr -d '\r' < "$T/refused.err" | grep -m1 '^imap: error' || true)
  [ $rc -eq 2 ] && [ -n "$msg" ] && ! grep -q panicked "$T/refused.err" \
    || { echo "$what: exit $rc (want 2)" >&2; tr -d '\r' < "$T/refused.err" >&2; exit 1; }
  echo "$what: $msg"
}
refused "imap.exe run NUL" run NUL --photons 10
refused "imap.exe run CON.obj" run 'CON.obj' --photons 10
refused "imap.exe run with a missing folder" run "$WM\\no such folder\\s.obj" --photons 10
refused "imap.exe run --out NUL" run "$WM\\s.obj" --config "$WM\\s.toml" --photons 10 --out NUL
refused "imap.exe resume of a folder" resume "$WM"
printf 'up_axis = "z"\n[[luminaire]]\nfile = "CON.ies"\nposition = [2, 2, 2.9]\n' > "$M/reserved.toml"
refused "imap.exe run with a luminaire file named CON.ies" run "$WM\\s.obj" --config "$WM\\reserved.toml" --photons 10
echo "windows: ok"
