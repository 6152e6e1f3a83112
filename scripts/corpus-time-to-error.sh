#!/usr/bin/env bash
# Time to a 2 % estimated global error of third-party models (Debian's assimp-testmodels)
# through the imap command, with point-light aiming (the default) and without it
# ([run] aim_lights = false), side by side. Each model gets a 1000 lm point light above it
# and off its axes at one model size (as in cli/tests/corpus.rs); the front sides are
# recorded (the default).
# Usage: scripts/corpus-time-to-error.sh [threads] [target] [max seconds]
set -euo pipefail
cd "$(dirname "$0")/.."
IMAP=${IMAP:-target/release/imap}
THREADS=${1:-2}
TARGET=${2:-0.02}
MAX=${3:-60}
M=/usr/share/assimp/models
MODELS="OBJ/WusonOBJ.obj OBJ/spider.obj OBJ/regr01.obj OBJ/concave_polygon.obj PLY/Wuson.ply
PLY/cube_uv.ply STL/Spider_binary.stl STL/3DSMaxExport.STL STL/sphereWithHole.stl
glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb glTF2/ClearCoat-glTF/ClearCoatTest.gltf
glTF2/BoxTextured-glTF-Binary/BoxTextured.glb glTF2/textureTransform/TextureTransformTest.gltf"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
echo "| model | triangles | result | aimed: time to ${TARGET} (s) | photons | not aimed: time (s) | photons | speed-up |"
echo "|---|---:|---|---:|---:|---:|---:|---:|"
for m in $MODELS; do
  f="$M/$m"
  if ! "$IMAP" info "$f" > "$TMP/info.json" 2> "$TMP/err"; then
    echo "| $m | | refused: $(head -1 "$TMP/err" | cut -c1-80) | | | | | |"
    continue
  fi
  read -r tris light < <(python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
lo, hi = d["bounds"]
c = [(a + b) / 2 for a, b in zip(lo, hi)]
s = max(max(b - a for a, b in zip(lo, hi)), 1e-3)
print(d["triangles"], [c[0] + 0.5 * s, hi[1] + s, c[2] + 0.7 * s])' "$TMP/info.json" | sed 's/ \[/ [/')
  row="| $m | $tris | ran"
  times=()
  for aim in true false; do
    printf '[run]\nseed = 1\naim_lights = %s\n[[light]]\nkind = "point"\nposition = %s\namount = 1000\nunit = "lm"\n' \
      "$aim" "$light" > "$TMP/s.toml"
    "$IMAP" run "$f" --config "$TMP/s.toml" --target-error "$TARGET" --time "$MAX" --photons 0 \
      --threads "$THREADS" --quiet --out "$TMP/out" > /dev/null 2>&1
    read -r t p stop < <(python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))
print(round(r["run_s"], 2), r["photons"], r["stop"])' "$TMP/out/report.json")
    [ "$stop" = TargetError ] || t=">$t"
    row="$row | $t | $p"
    times+=("$t")
  done
  sp=$(python3 -c 'import sys
a, b = sys.argv[1], sys.argv[2]
print("" if a.startswith(">") else ("≥" if b.startswith(">") else "") + "%.1f×" % (float(b.lstrip(">")) / float(a)))' "${times[0]}" "${times[1]}")
  echo "$row | $sp |"
done
