#!/usr/bin/env bash
# Submits the array job (one child per shard; `--shard auto` reads
# AWS_BATCH_JOB_ARRAY_INDEX, 0-based, and the count from AGVSIM_SHARD_COUNT, set here to
# the array's size) and a merge that depends on the whole array:
#   QUEUE=my-queue SHARDS=8 deploy/aws-batch/submit.sh
# Register the definition first: aws batch register-job-definition --cli-input-json file://job-definition.json
set -euo pipefail
: "${QUEUE:?set QUEUE to a job queue}"
SHARDS="${SHARDS:-8}"
array=$(aws batch submit-job --job-name agvsim-batch --job-queue "$QUEUE" \
  --job-definition agvsim-batch --array-properties "size=$SHARDS" \
  --container-overrides "environment=[{name=AGVSIM_SHARD_COUNT,value=$SHARDS}]" \
  --query jobId --output text)
aws batch submit-job --job-name agvsim-merge --job-queue "$QUEUE" \
  --job-definition agvsim-batch --depends-on "jobId=$array" \
  --container-overrides 'command=["sh","-c","exec agvsim batch merge /data/out/shard_* --out /data/out/merged"]'
# The merge runs once every child succeeded (dependsOn the array's parent job).
echo "array job $array"
