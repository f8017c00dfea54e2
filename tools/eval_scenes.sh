#!/usr/bin/env bash
# Renders each benchmark scene once into $ROOT (default /tmp/planemap-scenes) and runs the
# pipeline on it, printing one line per scene with the accuracy figures.
#
#   tools/eval_scenes.sh [--pmvs] [--scenes "room stairs"] [--size WxH] [-- extra run args]
#
# Extra arguments after `--` go to `planemap run` (e.g. --set planemap.lambda=0.5).
# BIN overrides the binary (default target/release/planemap), ROOT the render directory.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-target/release/planemap}
ROOT=${ROOT:-/tmp/planemap-scenes}
SCENES="demo room exterior stairs courtyard"
MODE=colmap
SIZE=""
while [ $# -gt 0 ]; do
  case "$1" in
    --pmvs) MODE=pmvs; shift ;;
    --scenes) SCENES="$2"; shift 2 ;;
    --size) SIZE="$2"; shift 2 ;;
    --) shift; break ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
size_args=()
tag=""
if [ -n "$SIZE" ]; then
  size_args=(--width "${SIZE%x*}" --height "${SIZE#*x}")
  tag="-$SIZE"
fi
for s in $SCENES; do
  ws="$ROOT/$s$tag"
  if [ ! -d "$ws/gt" ]; then
    "$BIN" -q synth "scenes/$s.toml" -o "$ws" "${size_args[@]}" >/dev/null
  fi
  out="$ws/out-$MODE"
  rm -rf "$out"
  start=$(date +%s.%N)
  if [ "$MODE" = pmvs ]; then
    # PMVS names its views 00000000, 00000001, … in image order; gt/ uses the image names.
    # Map them with a directory of links (the i-th gt file in name order is view i).
    gtp="$ws/gt-pmvs"
    if [ ! -d "$gtp" ]; then
      mkdir -p "$gtp/depth" "$gtp/planes"
      cp "$ws/gt/planes.json" "$gtp/"
      i=0
      for f in $(ls "$ws/gt/depth" | sort); do
        stem=$(printf "%08d" $i)
        ln -s "$ws/gt/depth/$f" "$gtp/depth/$stem.pfm"
        ln -s "$ws/gt/planes/${f%.pfm}.png" "$gtp/planes/$stem.png"
        i=$((i + 1))
      done
    fi
    res=$("$BIN" -q run --pmvs "$ws/pmvs" --gt "$gtp" -o "$out" "$@" 2>&1 || true)
  else
    res=$("$BIN" -q run --model "$ws/sparse" --images "$ws/images" -o "$out" "$@" 2>&1 || true)
  fi
  secs=$(echo "$(date +%s.%N) - $start" | bc)
  line=$(echo "$res" | grep -E "depth within" | tail -1 || true)
  [ -z "$line" ] && line="FAILED: $(echo "$res" | tail -2 | tr '\n' ' ')"
  printf "%-10s %-6s %6.1fs  %s\n" "$s" "$MODE" "$secs" "$line"
done
