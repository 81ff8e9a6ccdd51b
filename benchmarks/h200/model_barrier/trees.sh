# Sourced by the model-barrier campaigns (model_barrier/run.sh, overlap/barrier.sh) from the repo
# root: $O (the output folder, $OUT or /tmp/quadcos_out) with gpu.txt, and $sunk, a copy of the
# tree without the barrier (model_barrier.patch reversed: MJX-Warp's constant model fields left
# for XLA to sink into the substep loop, as before the barrier was the default).
set -u
O=${OUT:-/tmp/quadcos_out}; mkdir -p $O
nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
sunk=/tmp/quadcos_sunk
rm -rf $sunk && cp -r . $sunk &&
  (cd $sunk && patch -R -p1 < benchmarks/h200/model_barrier/model_barrier.patch) || exit 1
