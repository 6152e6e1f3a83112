#!/usr/bin/env bash
# The main job: builds libimap and the `imap` command and runs its demo, the Cornell box to
# 1 % estimated error, writing the map (PLY, CSV), report.json, convergence.png and
# view.png into imap-demo/ (or the folder `--out DIR` names). Other arguments go to
# `imap demo` (e.g. --target-error 0.02).
set -euo pipefail
cd "$(dirname "$0")/.."
EMBREE_DIR=$(scripts/setup-embree.sh)
export EMBREE_DIR
cargo build --release -p imap-cli
# The default folder only when the caller names none (clap refuses --out twice).
out=(--out imap-demo)
for a in "$@"; do
  case "$a" in
    --out|--out=*|-o|-o*) out=() ;;
  esac
done
exec target/release/imap demo "${out[@]}" "$@"
