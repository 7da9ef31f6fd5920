#!/usr/bin/env bash
# How many of flare's ghost paths get through the lens, pair by pair (docs/flare.md, "Waste per
# ghost"): the double Gauss at f/2 in an empty scene with a uniform sky, each ghost pair rendered
# alone ("string flareghosts" "I,J") at 64 x 48 pixels; prints the pair, its share of the ghost
# paths (the estimator's p), and the fraction of its paths that reach the scene (the render's
# "ghost rays" over its camera samples), then the whole estimator's fraction.
# Usage: bench/flare_ghost_waste.sh [LENSIM_BINARY]   (about a minute on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build/lensim}
lens=$(pwd)/lenses/dgauss.50mm.dat
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene() {  # FILE EXTRA
  cat > "$1" <<PBRT
Camera "realistic" "string lensfile" "$lens" "float aperturediameter" 17.1
  "float focusdistance" 25 "bool flare" true $2
Film "rgb" "integer xresolution" 64 "integer yresolution" 48 "float diagonal" 43.3
Sampler "independent" "integer pixelsamples" 64
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
PBRT
}
through() {  # SCENE -> "ghost rays / camera samples"
  "$bin" render "$1" --threads 2 --stats -o "$work/x.exr" 2>&1 |
    awk '/^camera samples/ { s = $3 } /^ghost rays/ { g = $3 }
         END { if (s > 0) printf "%.4f\n", g / s; else print "refused (reflects nothing)" }'
}
pairs=$("$bin" lens ghosts "$lens" --json | python3 -c '
import json, sys
for g in json.load(sys.stdin)["ghosts"]:
    print("%d,%d" % (g["first_reflection_surface"], g["second_reflection_surface"]))')
echo "pair  fraction through"
for p in $pairs; do
  scene "$work/p.pbrt" "\"string flareghosts\" \"$p\""
  printf '%-6s %s\n' "$p" "$(through "$work/p.pbrt" 2>/dev/null || true)"
done
scene "$work/all.pbrt" ""
echo "all pairs (the estimator's mix): $(through "$work/all.pbrt")"
