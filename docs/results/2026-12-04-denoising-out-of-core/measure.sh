#!/bin/bash
# Denoising out of core vs in core, release build of the commit under test.
set -u
PSI=/work/main/target/release/psi
OUT=/tmp/ood2; rm -rf $OUT; mkdir -p $OUT
run() { # tag input [flags...]
  local tag=$1 in=$2; shift 2
  /usr/bin/time -f "%e s %M KB" -o $OUT/$tag.time $PSI sample "$in" -q -o $OUT/$tag.ply --json $OUT/$tag.json "$@"
  echo "$tag rc=$? $(cat $OUT/$tag.time)"
}
for m in bunny-noise-0.5 horse-noise-0.25 igea-noise-0.5 igea-noise-0.25; do
  in=/work/main/target/xtask/scans/$m.xyz
  run $m-core $in
  run $m-64MiB $in --max-memory 64MiB --scratch $OUT/$m-s64
  run $m-1GiB $in --max-memory 1GiB --scratch $OUT/$m-s1G
done
in=/tmp/ood/noisy2m.xyz
run noisy2m-core $in
run noisy2m-1GiB $in --max-memory 1GiB --scratch $OUT/noisy2m-s1G
run noisy2m-256MiB $in --max-memory 256MiB --scratch $OUT/noisy2m-s256
# resumed: the checks and the denoised store found
run noisy2m-1GiB-again $in --max-memory 1GiB --scratch $OUT/noisy2m-s1G
for f in $OUT/*.ply; do :; done
echo done
