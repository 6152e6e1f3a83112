#!/usr/bin/env bash
# The Windows build (issue 35), cross-built here and run under Wine: scripts/build-windows.sh
# makes the package; the C tests and examples that need no POSIX calls are built with MinGW
# against it (one through the MSVC import library imap.lib), the header is compiled as C89
# -pedantic and as C++17; then under Wine they run, and imap.exe runs its analytic
# validation and a map that must equal the Linux command's for the same seed, settings and
# one thread, number for number, from a folder whose name has a space and a non-ASCII
# letter. Needs what build-windows.sh needs and Wine (scripts/setup-system.sh installs
# them; the Rust target is added here).
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
trap 'rm -rf "$T"' EXIT
CC=x86_64-w64-mingw32-gcc
CXX=x86_64-w64-mingw32-g++
INC="-I$PKG/include"

echo "== the header under MinGW: C89 -pedantic and C++17"
$CC -std=c89 -pedantic -Wall -Wextra -Werror $INC c_examples/c89_header.c -L"$PKG/lib" -limap -o "$T/c89_header.exe"
$CXX -std=c++17 -Wall -Wextra -Werror $INC -x c++ -fsyntax-only - <<<'#include "imap.hpp"
int main() { return 0; }'

echo "== C tests and examples built against the package"
TESTS="bad_input glare host_bsdf threaded_splits"
EXAMPLES="cornell_box legacy_names render_cornell"
for t in $TESTS; do $CC -std=c99 -O2 $INC "c_tests/$t.c" -L"$PKG/lib" -limap -lm -o "$T/$t.exe"; done
for e in $EXAMPLES; do $CC -std=c99 -O2 $INC "c_examples/$e.c" -L"$PKG/lib" -limap -lm -o "$T/$e.exe"; done
# A Visual C++ program links imap.lib: here MinGW's linker reads the same import library.
$CC -std=c99 -O2 $INC c_tests/bad_input.c "$PKG/lib/imap.lib" -lm -o "$T/bad_input_msvc_implib.exe"
$CXX -std=c++17 -O2 $INC c_examples/raii_room.cpp -L"$PKG/lib" -limap -static-libstdc++ -static-libgcc -o "$T/raii_room.exe"
cp "$PKG"/bin/*.dll "$T/"
printf 'LIBRARY bcryptprimitives\nEXPORTS\nProcessPrng\n' > "$T/bcp.def"
cat > "$T/bcp.c" <<'C'
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
$CC -O2 -shared -o "$T/bcryptprimitives.dll" "$T/bcp.c" "$T/bcp.def" -ladvapi32

echo "== under Wine"
export WINEPREFIX="$T/wine" WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml="
wine wineboot --init >/dev/null 2>&1 || true
run() { # run NAME: the program's last line, or its whole output when it fails
  local out rc=0
  out=$(cd "$T" && timeout 600 wine "$1.exe" 2>&1) || rc=$?
  if [ $rc -ne 0 ]; then echo "$out" >&2; echo "$1.exe under Wine: exit $rc" >&2; exit 1; fi
  echo "$1.exe: $(echo "$out" | tr -d '\r' | tail -1)"
}
for p in c89_header $TESTS bad_input_msvc_implib $EXAMPLES raii_room; do run "$p"; done

echo "== imap.exe under Wine: the analytic validation, and the same map as Linux"
cp "$PKG/bin/imap.exe" "$T/"
(cd "$T" && timeout 600 wine imap.exe --version | tr -d '\r')
(cd "$T" && timeout 600 wine imap.exe validate --photons 200000 | tr -d '\r' | tail -4)
M="$T/model dir ä"
mkdir -p "$M"
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
ARGS="--photons 300000 --threads 1 --seed 7 --scheduler classic --quiet"
target/release/imap run "$M/s.obj" --config "$M/s.toml" $ARGS --out "$T/linux" >/dev/null 2>&1
WM=$(winepath -w "$M")
(cd "$T" && timeout 600 wine imap.exe run "$WM\\s.obj" --config "$WM\\s.toml" $ARGS --out windows >/dev/null 2>&1)
cmp "$T/linux/irradiance.csv" <(tr -d '\r' < "$T/windows/irradiance.csv") \
  || { echo "imap.exe's map under Wine differs from Linux's" >&2; diff "$T/linux/irradiance.csv" "$T/windows/irradiance.csv" | head >&2; exit 1; }
echo "imap.exe under Wine: the map equals Linux's, $(($(wc -l < "$T/linux/irradiance.csv") - 1)) vertex rows, read from \"$WM\""
# A reserved name and a missing file: a clear error, not a crash.
rc=0; (cd "$T" && timeout 600 wine imap.exe run 'NUL' --photons 10 >/dev/null 2>"$T/nul.err") || rc=$?
[ $rc -eq 2 ] || { echo "imap.exe run NUL: exit $rc (want 2)" >&2; cat "$T/nul.err" >&2; exit 1; }
echo "imap.exe run NUL: $(tr -d '\r' < "$T/nul.err" | head -1)"
echo "windows: ok"
