#!/usr/bin/env bash
# Cross-builds libimap for Windows x64 (issue 35) on Debian, and assembles a relocatable
# Windows package in target/windows/imap-VERSION-windows-x64:
#   bin/      imap.dll, imap.exe, and Embree's embree4.dll, tbb12.dll and their C++ runtime
#             (the pinned embreex==4.4.0.post1 win_amd64 wheel, hash-checked) beside them,
#             where Windows finds DLLs;
#   lib/      libimap.dll.a (MinGW) and imap.lib (MSVC, from imap.def by llvm-dlltool, else
#             binutils' dlltool), imap.def;
#   include/  imap.h, imap.hpp;
#   lib/cmake/imap/imapConfig.cmake (imported target imap::imap for MSVC and MinGW
#             consumers: IMPORTED_LOCATION the DLL, IMPORTED_IMPLIB the import library);
#   lib/pkgconfig/imap.pc.
# Needs: the Rust target x86_64-pc-windows-gnu (rustup target add), Debian's
# gcc-mingw-w64-x86-64 (its binutils: dlltool, windres for the version resources), clang's
# headers for bindgen (libclang-dev, whose LLVM brings llvm-dlltool), pip3, unzip.
# `scripts/setup-system.sh` installs them.
# Prints the package's directory on its last line.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
TARGET=x86_64-pc-windows-gnu
WHEEL_VERSION=4.4.0.post1
WHEEL_SHA256=3df27becf6a12b59f5a469bc5271622e26387d52a15880edd29aa564246e7176
VERSION=$(sed -n 's/^version = "\(.*\)"/\1/p' "$ROOT/Cargo.toml" | head -1)
DLLS="$ROOT/deps/embree4-windows"
PKG="$ROOT/target/windows/imap-$VERSION-windows-x64"

log() { echo "build-windows: $*" >&2; }

for tool in x86_64-w64-mingw32-gcc x86_64-w64-mingw32-dlltool x86_64-w64-mingw32-objdump \
            x86_64-w64-mingw32-strip pip3 unzip sha256sum; do
  command -v "$tool" >/dev/null || { log "missing tool '$tool' (run scripts/setup-system.sh as root)"; exit 1; }
done
rustup target list --installed 2>/dev/null | grep -qx "$TARGET" \
  || { log "the Rust target $TARGET is missing: rustup target add $TARGET"; exit 1; }

# 1. Embree and TBB as Windows DLLs, from the pinned wheel (ignored by git).
if [ ! -f "$DLLS/.complete" ]; then
  TMP=$(mktemp -d)
  trap 'rm -rf "$TMP"' EXIT
  log "downloading embreex==$WHEEL_VERSION (win_amd64) from PyPI"
  pip3 download --quiet --no-deps --only-binary=:all: --platform win_amd64 \
    --python-version 3.11 "embreex==$WHEEL_VERSION" -d "$TMP" >&2
  WHL=$(ls "$TMP"/embreex-*win_amd64.whl)
  echo "$WHEEL_SHA256  $WHL" | sha256sum -c --quiet - >&2 || { log "wheel hash mismatch"; exit 1; }
  unzip -q "$WHL" 'embreex.libs/*' -d "$TMP/x"
  rm -rf "$DLLS"; mkdir -p "$DLLS"
  cp "$TMP"/x/embreex.libs/*.dll "$DLLS/"
  touch "$DLLS/.complete"
fi

# 2. The DLL and the command. bindgen (embree4-sys) parses Embree's headers for the
#    target: clang's own headers and MinGW's.
CLANG_INC=$(ls -d /usr/lib/llvm-*/lib/clang/*/include 2>/dev/null | sort -V | tail -1)
[ -n "$CLANG_INC" ] || { log "no clang headers (libclang-dev)"; exit 1; }
export BINDGEN_EXTRA_CLANG_ARGS_x86_64_pc_windows_gnu="-I$CLANG_INC -I/usr/x86_64-w64-mingw32/include"
export EMBREE_DIR="$DLLS"
# No debug info in the shipped DLL and EXE (the Linux profile keeps it for backtraces):
# a quicker build, and smaller files.
export CARGO_PROFILE_RELEASE_DEBUG=0
# One cargo build of both packages (their default targets: the library's cdylib and rlib,
# the command's binary): the dependencies' features are unified once and the library is
# compiled once (two builds compiled it twice, the command's deps asking more of `image`).
log "cargo build --target $TARGET (library and command)"
(cd "$ROOT" && cargo build --release --locked --target "$TARGET" -p imap -p imap-cli >&2)
OUT="$ROOT/target/$TARGET/release"

# 3. The package.
rm -rf "$PKG"; mkdir -p "$PKG/bin" "$PKG/lib/cmake/imap" "$PKG/lib/pkgconfig" "$PKG/include"
cp "$OUT/imap.dll" "$OUT/imap.exe" "$PKG/bin/"
x86_64-w64-mingw32-strip --strip-debug "$PKG/bin/imap.dll" "$PKG/bin/imap.exe"
cp "$DLLS"/*.dll "$PKG/bin/"
cp "$OUT/libimap.dll.a" "$PKG/lib/"
cp "$ROOT/include/imap.h" "$ROOT/include/imap.hpp" "$PKG/include/"
# The exports as a .def (the DLL's export table), and MSVC's import library from it.
{
  echo "LIBRARY imap.dll"
  echo "EXPORTS"
  x86_64-w64-mingw32-objdump -p "$PKG/bin/imap.dll" \
    | awk '/\[Ordinal\/Name Pointer\] Table/ {on = 1; next} on && /^[ \t]*\[/ {print "    " $NF; next} on && NF == 0 {on = 0}'
} > "$PKG/lib/imap.def"
EXPORTS=$(grep -c '^    imap_' "$PKG/lib/imap.def" || true)
[ "$EXPORTS" -gt 100 ] || { log "imap.def lists $EXPORTS imap_ functions: the export table was not read"; exit 1; }
# LLVM's dlltool writes the short import format of Microsoft's lib.exe (what link.exe
# expects of an import library); binutils' dlltool, the fallback, writes long-form objects.
LLVM_DLLTOOL=$(ls /usr/lib/llvm-*/bin/llvm-dlltool 2>/dev/null | sort -V | tail -1 || true)
if [ -n "$LLVM_DLLTOOL" ]; then
  "$LLVM_DLLTOOL" -m i386:x86-64 -d "$PKG/lib/imap.def" -D imap.dll -l "$PKG/lib/imap.lib"
else
  x86_64-w64-mingw32-dlltool -d "$PKG/lib/imap.def" -D imap.dll -m i386:x86-64 -l "$PKG/lib/imap.lib"
fi
cat > "$PKG/lib/cmake/imap/imapConfig.cmake" <<CMAKE
# CMake package config of libimap $VERSION for Windows x64 (scripts/build-windows.sh).
#   find_package(imap CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE imap::imap)
# MSVC links lib/imap.lib, MinGW lib/libimap.dll.a; both load bin/imap.dll, which finds
# Embree and TBB beside it. Copy bin/*.dll beside your executable (or put bin/ on PATH).
get_filename_component(_imap_prefix "\${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
if(NOT TARGET imap::imap)
  add_library(imap::imap SHARED IMPORTED)
  if(MSVC)
    set(_imap_implib "\${_imap_prefix}/lib/imap.lib")
  else()
    set(_imap_implib "\${_imap_prefix}/lib/libimap.dll.a")
  endif()
  set_target_properties(imap::imap PROPERTIES
    IMPORTED_LOCATION "\${_imap_prefix}/bin/imap.dll"
    IMPORTED_IMPLIB "\${_imap_implib}"
    INTERFACE_INCLUDE_DIRECTORIES "\${_imap_prefix}/include")
  unset(_imap_implib)
endif()
set(imap_VERSION $VERSION)
set(imap_FOUND TRUE)
unset(_imap_prefix)
CMAKE
cat > "$PKG/lib/pkgconfig/imap.pc" <<PC
prefix=\${pcfiledir}/../..
libdir=\${prefix}/lib
includedir=\${prefix}/include

Name: imap
Description: Illumination maps by forward Monte Carlo light tracing on Embree 4 (Windows x64)
Version: $VERSION
Libs: -L\${libdir} -limap
Cflags: -I\${includedir}
PC
log "package: $PKG ($EXPORTS functions exported)"
echo "$PKG"
