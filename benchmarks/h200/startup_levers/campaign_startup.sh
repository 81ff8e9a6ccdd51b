#!/usr/bin/env bash
# Issue 33 item 4: start-up, this tree against base_tree (the revision before the device thread).
set -u
echo "start $(date +%T)"
export OUT=$OUT/startup; mkdir -p $OUT
BASE_TREE=$PWD/base_tree bash benchmarks/h100/startup/before_after.sh
cat $OUT/status
echo CAMPAIGN DONE
