# CMake toolchain: cross-compiles for Windows x64 with Debian's MinGW-w64 and runs the
# results under Wine (CMAKE_CROSSCOMPILING_EMULATOR), so that ctest runs a Windows build's
# tests here. scripts/test-windows.sh configures c_tests and c_examples with it against the
# Windows package (find_package(imap) through CMAKE_PREFIX_PATH):
#   cmake -S c_tests -B build-win -DCMAKE_TOOLCHAIN_FILE=cmake/mingw-w64-wine.cmake \
#         -DCMAKE_PREFIX_PATH=target/windows/imap-VERSION-windows-x64
# Wine finds imap.dll, Embree and TBB through WINEPATH (the package's bin), which the
# caller sets, with WINEPREFIX.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)
set(CMAKE_C_COMPILER x86_64-w64-mingw32-gcc)
set(CMAKE_CXX_COMPILER x86_64-w64-mingw32-g++)
set(CMAKE_RC_COMPILER x86_64-w64-mingw32-windres)
set(CMAKE_FIND_ROOT_PATH /usr/x86_64-w64-mingw32)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
# The package is found where the caller points (CMAKE_PREFIX_PATH), outside MinGW's root.
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# The test programs carry MinGW's own runtime (libgcc, libstdc++, winpthreads) inside
# them; the package's DLLs are all they load.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-static")
find_program(IMAP_WINE NAMES wine wine64 REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR ${IMAP_WINE})
