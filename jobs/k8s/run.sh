#!/usr/bin/env bash
# A sharded twoscale build on Kubernetes: the Indexed Job of shards.yaml,
# then, once every shard has completed, the merge Job of merge.yaml. Running
# it again after a failure resumes: the Jobs are recreated and the shards
# already on the volume are skipped.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
timeout=${TIMEOUT:-48h}

# Waits until the Job completes (status 0) or fails (status 1).
wait_job() {
    kubectl wait --for=condition=complete "job/$1" --timeout="$timeout" >/dev/null &
    local complete=$!
    kubectl wait --for=condition=failed "job/$1" --timeout="$timeout" >/dev/null &
    local failed=$!
    wait -n "$complete" "$failed" || true
    if kubectl get "job/$1" -o jsonpath='{.status.conditions[?(@.type=="Complete")].status}' | grep -q True; then
        kill "$failed" 2>/dev/null || true
        return 0
    fi
    kill "$complete" "$failed" 2>/dev/null || true
    return 1
}

kubectl delete job twoscale-shards twoscale-merge --ignore-not-found
kubectl apply -f "$here/shards.yaml"
if ! wait_job twoscale-shards; then
    echo "run.sh: a shard failed: kubectl logs -l role=shard --prefix; fix it and run this again" >&2
    exit 1
fi
kubectl apply -f "$here/merge.yaml"
if ! wait_job twoscale-merge; then
    echo "run.sh: the merge failed: kubectl logs -l role=merge (the line names the bad shard)" >&2
    exit 1
fi
echo "run.sh: merged; the tables are on the volume under tables-out/"
