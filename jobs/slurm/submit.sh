#!/usr/bin/env bash
# Submits a sharded twoscale build to SLURM: an array job of N shards and a
# merge job that runs when every shard has succeeded (afterok; cancelled if
# one fails). Prints the two job ids.
#
#   jobs/slurm/submit.sh N [twoscale build options]
#   TWOSCALE=/shared/bin/twoscale TWOSCALE_OUT=/shared/tables-out jobs/slurm/submit.sh 16 --preset default
#
# Logs: $TWOSCALE_OUT/logs/<preset>-shard-<K>.log and <preset>-merge.log.
# After a failure, run the same command again: finished shards are skipped.
# TWOSCALE_WAIT=1 waits for the merge and exits with its status;
# SBATCH_OPTIONS adds sbatch options to both jobs (e.g. "--partition=long").
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
n=${1:?usage: submit.sh N [twoscale build options]}
shift
out=${TWOSCALE_OUT:-tables-out}
# The directory the merge reads: the preset, or scene-<file stem> for --scene.
target=default
merge_args=()
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
    case ${args[i]} in
        --preset) target=${args[i + 1]} ;;
        --preset=*) target=${args[i]#*=} ;;
        --scene) f=$(basename "${args[i + 1]}"); target=scene-${f%.*} ;;
        --scene=*) f=$(basename "${args[i]#*=}"); target=scene-${f%.*} ;;
        --table) merge_args+=(--table "${args[i + 1]}") ;;
        --out | --out=*) echo "submit.sh: set TWOSCALE_OUT instead of --out" >&2; exit 2 ;;
        --shard | --shard=*) echo "submit.sh: the array sets --shard" >&2; exit 2 ;;
    esac
done
mkdir -p "$out/logs"
export TWOSCALE_OUT=$out TWOSCALE_SHARDS=$n
# shellcheck disable=SC2086
array=$(sbatch --parsable ${SBATCH_OPTIONS:-} --array="0-$((n - 1))" --output="$out/logs/$target-shard-%a.log" \
    "$here/shard.sbatch" "$@")
array=${array%%;*}
echo "shards: job $array (logs $out/logs/$target-shard-*.log)"
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${SBATCH_OPTIONS:-} ${TWOSCALE_WAIT:+--wait} --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$out/logs/$target-merge.log" "$here/merge.sbatch" --preset "$target" "${merge_args[@]}") || {
    status=$?
    echo "submit.sh: the merge failed or was cancelled because a shard failed (exit $status):" \
         "see $out/logs/$target-*.log, then run this command again (finished shards are skipped)" >&2
    exit "$status"
}
echo "merge: job ${merge%%;*} (log $out/logs/$target-merge.log)"
