#!/usr/bin/env bash
# The scaling table of docs/performance.md (issue #14 item 3): the exact tracer, ROMA, the voxel
# array and DVF on the bunny family at 69K / 278K / 1.04M triangles (scenes/scaling/, and the
# suite's million-triangles). Needs ../shared (the bunny) and a release build:
#   cargo build --release && tools/scaling.sh > scaling.log
set -euo pipefail
cd "$(dirname "$0")/.."
G=${GLIMPSE:-target/release/glimpse}
out=$(mktemp -d)
for s in scenes/scaling/bunnies-1.toml scenes/scaling/bunnies-4.toml scenes/suite/million-triangles.toml; do
  echo "== $s"
  # Shadow rays through the voxel arrays (their builds are timed as 'build ms'), AO rays through ROMA.
  GLIMPSE_CACHE= "$G" bench rays "$s" --kind shadow --size 1280x720 --rays 2000000 --only voxarray-vq,voxarray
  GLIMPSE_CACHE= "$G" bench rays "$s" --kind ao --rays 2000000 --only roma
  # DVF's frame (its per-frame build included) against env-exact, and each one's peak memory.
  for t in env-exact env-dvf; do
    GLIMPSE_CACHE= /usr/bin/time -f "$t peak RSS %M KB" "$G" render "$s" -t "$t" --size 320x180 -o "$out/$t.exr"
  done
done
rm -rf "$out"
