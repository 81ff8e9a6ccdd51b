#!/usr/bin/env bash
# Waits up to SECONDS (default 540) for experiments/gpu_campaign.sh, returning early when it is
# done, then copies its finished phases, status and log tail to $OUT (what the device call returns).
secs=${1:-540}
C=/tmp/campaign
end=$(( $(date +%s) + secs ))
while [ "$(date +%s)" -lt "$end" ] && ! grep -q "campaign done" $C/status 2>/dev/null; do sleep 5; done
cp $C/*.tar.gz $C/status $C/gpu.txt "$OUT"/ 2>/dev/null
# Runs still going (or whose phase never finished): their metrics and logs so far, so that a
# machine lost between calls still leaves the training curves.
for run in $C/*/runs/*/; do
  [ -d "$run" ] || continue
  dest="$OUT/progress/$(basename "$(dirname "$(dirname "$run")")")/$(basename "$run")"
  mkdir -p "$dest" && cp "$run"train.log "$dest"/ 2>/dev/null
  cp /tmp/quadcos_runs/$(basename "$run")/metrics.jsonl "$dest"/ 2>/dev/null
done
tail -c 6000 /tmp/campaign.log > "$OUT"/campaign_tail.log 2>/dev/null
cat $C/status 2>/dev/null
nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader
