# One H200: the 1-update flat row traced (quadcos.bench --profile_dir; traces not kept), default against
# graph_mode=jax with loops and branches in command buffers; summaries and gaps beside it.
O=$OUT; mkdir -p $O
for v in default jax_gc0_while; do
  if [ $v = default ]; then X=""; E=""; else X="--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL"; E="--env warp.graph_mode=jax --env warp.graph_conditional=false"; fi
  XLA_FLAGS="--xla_gpu_triton_gemm_any=true $X" timeout 250 python3 -m quadcos.bench --impl=warp --terrain=flat --only=train \
    --train_rows=4096x8192x1 --train_seconds=8 $E --profile_dir=/tmp/prof_$v --out=$O/bench_trace_$v.json > $O/bench_trace_$v.log 2>&1
  echo "$(date +%T) $v exit $? $(grep -o 'train 4096x8192x1: [^,]*' $O/bench_trace_$v.log)"
  for d in /tmp/prof_$v/*/; do
    python3 -m quadcos.benchmarking.profile $d > $O/summary_$v.md 2>&1
    python3 -m quadcos.benchmarking.profile $d --gaps --top 25 > $O/gaps_$v.md 2>&1
  done
  head -30 $O/summary_$v.md
done
echo CAMPAIGN DONE
