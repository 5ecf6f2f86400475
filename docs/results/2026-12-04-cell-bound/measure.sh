#!/bin/bash
# The cell bound and the process's baseline in the budget (release build of the commit under
# test). Inputs: the shared bunny mesh and real scan, and the scans' noisy bunny
# (`cargo xtask scans --only variants,bunny` writes it). Every run from an empty scratch.
set -u
PSI=/work/main/target/release/psi
OUT=/tmp/cellbound; rm -rf $OUT; mkdir -p $OUT
NOISY=/work/main/target/xtask/scans/bunny-noise-0.5.xyz
BUNNY=/work/shared/models/bunny.ply
SCAN=/work/shared/scans/dragon_stand_scan.xyz
run() { # tag input [flags...]
  local tag=$1 in=$2; shift 2
  rm -rf $OUT/$tag.s
  /usr/bin/time -f "%e %M" -o $OUT/$tag.time $PSI sample "$in" -q -o $OUT/$tag.ply \
    --json $OUT/$tag.json --scratch $OUT/$tag.s "$@" 2> $OUT/$tag.err
  echo "$tag rc=$? $(tail -1 $OUT/$tag.time)"
}
run bunny-64MiB $BUNNY --max-memory 64MiB
run bunny-96MiB $BUNNY --max-memory 96MiB
run noisy-bunny-128MiB $NOISY --max-memory 128MiB
run noisy-bunny-nne-64MiB $NOISY --no-noise-estimate --max-memory 64MiB
run noisy-bunny-nne-256MiB $NOISY --no-noise-estimate --max-memory 256MiB
run noisy-bunny-nne-1GiB $NOISY --no-noise-estimate --max-memory 1GiB
run noisy-bunny-nne-2GiB $NOISY --no-noise-estimate --max-memory 2GiB
for i in 1 2 3; do run scan-256MiB-$i $SCAN --max-memory 256MiB; done
# In core, for the bytes.
/usr/bin/time -f "%e %M" -o $OUT/scan-core.time $PSI sample $SCAN -q -o $OUT/scan-core.ply 2>/dev/null
echo "scan-core $(tail -1 $OUT/scan-core.time)"
for i in 1 2 3; do cmp -s $OUT/scan-core.ply $OUT/scan-256MiB-$i.ply && echo "scan-256MiB-$i same bytes"; done
