#!/usr/bin/env bash
# Issue #13's memory target: the peak RSS of every technique on every suite scene at 1280×720
# (one frame, 1 spp, empty disk caches so that every build is included). Needs ../shared (most
# suite scenes) and a release build:
#   cargo build --release && tools/memory_1280.sh > memory.log
# Prints "scene technique peak_GiB" per line; a technique a scene cannot run (no area light, no
# environment, an animated scene for the wavelet cache) prints its one-line reason instead.
set -uo pipefail
cd "$(dirname "$0")/.."
G=${GLIMPSE:-target/release/glimpse}
out=$(mktemp -d)
export GLIMPSE_CACHE="$out/cache"
for s in scenes/suite/*.toml; do
  for t in ao-df ao-roma gi-roma soft-df soft-roma env-dvf lights-ism lights-shadowmap lights-voxarray vpl-lightcuts vpl-sst vpl-rtslc wavecache; do
    if /usr/bin/time -f "%M" -o "$out/rss" "$G" render "$s" -t "$t" --size 1280x720 --spp 1 -o "$out/img.exr" > "$out/log" 2>&1; then
      awk -v s="$(basename "$s" .toml)" -v t="$t" '{printf "%s %s %.2f\n", s, t, $1 / 1048576}' "$out/rss"
    else
      echo "$(basename "$s" .toml) $t not run: $(grep -m1 '^error' "$out/log")"
    fi
    rm -rf "$GLIMPSE_CACHE"
  done
done
rm -rf "$out"
