# One H200: training with the solver's early exit off, Warp's own graphs (gc0) against XLA's (jax_gc0_while), beside the default; --only=train.
# Run from the repo root after `source experiments/gpu_setup.sh` with warp-lang installed: bash campaign.sh OUTDIR.
O=$1; mkdir -p $O; nvidia-smi --query-gpu=name --format=csv,noheader > $O/gpu.txt
W=--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL
b() { local name=$1 xla=$2; shift 2
  XLA_FLAGS="--xla_gpu_triton_gemm_any=true $xla" timeout 150 python3 -m quadcos.bench --impl=warp --terrain=flat --only=train \
    --train_rows=4096x8192x1 --train_seconds=8 --out=$O/bench_${name}_flat.json "$@" > $O/bench_${name}_flat.log 2>&1
  echo "$(date +%T) $name exit $? $(grep -o 'train 4096x8192x1: [^,]*' $O/bench_${name}_flat.log)"; }
b default ""
b gc0 "" --env warp.graph_conditional=false
b jax_gc0_while "$W" --env warp.graph_mode=jax --env warp.graph_conditional=false
echo CAMPAIGN DONE
