#!/usr/bin/env bash
# Runs every test of libimap (after scripts/setup-system.sh has installed the system
# packages): formatting, clippy and rustdoc without warnings, the Rust unit and integration
# tests (physics against analytic answers,
# determinism across schedulers and thread counts, the header drift check), the loom model
# of the dynamic scheduler's split protocol, the CMake build with the C and C++ examples under
# ctest, and the package as a user gets it: installed into a prefix that is then moved,
# with c_examples configured on their own against it (CMake config) and one example built
# with pkg-config.
set -euo pipefail
cd "$(dirname "$0")/.."
EMBREE_DIR=$(scripts/setup-embree.sh)
export EMBREE_DIR
JOBS=$(nproc)

echo "== formatting, lints and the API docs: cargo fmt --check, clippy -D warnings, rustdoc -D warnings"
# rustfmt and clippy come with rustup's default profile; a toolchain without them gets
# them added, and is named (not silently passed) if that cannot be done.
for tool in fmt clippy; do
  cargo "$tool" --version >/dev/null 2>&1 || rustup component add "$( [ "$tool" = fmt ] && echo rustfmt || echo clippy )" >/dev/null 2>&1 || true
done
if cargo fmt --version >/dev/null 2>&1; then cargo fmt --all --check; else echo "WARNING: rustfmt is not installed: formatting not checked" >&2; fi
if cargo clippy --version >/dev/null 2>&1; then
  # In the release profile, as the tests below: the build scripts (embree4-sys's bindgen)
  # and proc-macros are then built once for both, not once per profile.
  cargo clippy --release --workspace --all-targets -- -D warnings
else
  echo "WARNING: clippy is not installed: lints not checked" >&2
fi
# (Two runs: the command's binary and the library share the name imap, and one cargo doc
# of both would write them to the same place.)
RUSTDOCFLAGS=-Dwarnings cargo doc --release --no-deps -p imap
RUSTDOCFLAGS=-Dwarnings cargo doc --release --no-deps -p imap-cli

echo "== cargo test (release; with fault injection, which the shipped library leaves out)"
# The library's, the command's and the integration tests; the benchmark examples are
# checked by clippy above (--all-targets) and not built again in release: no test runs them.
cargo test --release --workspace --lib --bins --tests --features imap/fault-injection

echo "== the README's main job, into a folder of the caller's: scripts/demo.sh --out DIR"
DEMO=$(mktemp -d)
scripts/demo.sh --out "$DEMO/out" --target-error 0.05 >/dev/null
test -s "$DEMO/out/report.json" && test -s "$DEMO/out/view.png" || { echo "demo.sh --out wrote no outputs" >&2; exit 1; }
rm -rf "$DEMO"
echo "demo.sh --out: ok"

echo "== ABI of libimap.so against the baseline in abi/ (abidiff and the header's layout)"
# cargo test builds the library as an rlib only (and with fault injection): build the
# shared library users get, without it, and check it reads no environment variable.
cargo build --release -p imap --lib
if strings target/release/libimap.so | grep -c IMAP_TEST_FAULT >/dev/null; then
  echo "the shipped library reads IMAP_TEST_FAULT" >&2; exit 1
fi
scripts/abi-check.sh target/release/libimap.so

echo "== loom: the vertex-group split protocol, the processing threads' sleep and the photon maps' active-thread counter"
# The models compile the three protocols' source files into the small crate loom/ (not the
# whole library): a minute less of building.
RUSTFLAGS="--cfg loom" CARGO_TARGET_DIR=target/loom cargo test --release -p imap-loom

echo "== CMake build tree: C and C++ examples under ctest"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DIMAP_EMBREE_DIR="$EMBREE_DIR" >/dev/null
cmake --build build -j "$JOBS"
ctest --test-dir build --output-on-failure -j "$JOBS"

echo "== installed package, relocated: find_package(imap) and pkg-config"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
cmake --install build --prefix "$TMP/first" >/dev/null
mv "$TMP/first" "$TMP/prefix"
# Bundled Embree and TBB live in a private directory, never beside system libraries.
if ls "$TMP/prefix/lib/"libtbb* "$TMP/prefix/lib/"libembree* >/dev/null 2>&1; then
  echo "installed Embree/TBB into PREFIX/lib, where they shadow system libraries" >&2; exit 1
fi
REAL=$(ls "$TMP/prefix/lib/"libimap.so.*.*.*)
readelf -d "$REAL" | grep -q 'RUNPATH.*\[\$ORIGIN/imap\]' || { echo "libimap's runpath is not \$ORIGIN/imap" >&2; exit 1; }
if [ -e "$EMBREE_DIR/libtbb.so.12" ] && [ "${EMBREE_DIR#/usr/}" = "$EMBREE_DIR" ]; then
  [ -e "$TMP/prefix/lib/imap/libtbb.so.12" ] && [ -e "$TMP/prefix/lib/imap/libembree4.so.4" ] \
    || { echo "bundled Embree/TBB missing from PREFIX/lib/imap" >&2; exit 1; }
fi
echo "installed layout: libimap in lib/, Embree and TBB in lib/imap/ (runpath \$ORIGIN/imap)"
cmake -S c_examples -B "$TMP/examples" -DCMAKE_PREFIX_PATH="$TMP/prefix" >/dev/null
cmake -S c_tests -B "$TMP/tests" -DCMAKE_PREFIX_PATH="$TMP/prefix" >/dev/null
cmake --build "$TMP/tests" -j "$JOBS"
cmake --build "$TMP/examples" -j "$JOBS"
PKG_CONFIG_PATH="$TMP/prefix/lib/pkgconfig" cc -std=c11 -Wall -Wextra -Wpedantic -Werror \
  c_tests/bad_input.c $(PKG_CONFIG_PATH="$TMP/prefix/lib/pkgconfig" pkg-config --cflags --libs imap) -lm \
  -o "$TMP/examples/bad_input_pkgconfig"
"$TMP/examples/bad_input_pkgconfig" >/dev/null
echo "pkg-config build of bad_input: ok"
# Every example is built against the relocated package; the long physics runs
# (luminaire_room, the renders) passed above on the same sources, so the installed tree runs
# the quick ones: linking and running against the package is what is checked here.
ctest --test-dir "$TMP/examples" --output-on-failure -j "$JOBS" -E 'luminaire_room|render_cornell|edge_lit_panel'

echo "== Windows: the DLL, the command and the package cross-built with MinGW, run under Wine"
scripts/test-windows.sh
