#!/usr/bin/env bash
# Submit a catalogue to Slurm as a job array of TASKS shards (tools/slurm/brdf-array.sbatch).
#
#   tools/slurm/submit.sh CATALOGUE OUTDIR [TASKS] [-- SBATCH_OPTION...]
#
#   CATALOGUE  a catalogue or spec file (.json), on the shared filesystem
#   OUTDIR     output folder on the shared filesystem (created); task logs go to OUTDIR/logs/
#   TASKS      array size N (default: one task per material, at most 1000, below Slurm's default
#              MaxArraySize of 1001). Task I computes materials I, I+N, I+2N, ...
#   after --    passed to sbatch before the script, e.g. -- --partition=cpu --cpus-per-task=8
#              --time=12:00:00, or for GPUs: -- --gres=gpu:1 --cpus-per-task=2 (with BRDF_DEVICE=opencl)
#
# Environment: BRDFTOOL (default: build/bin/brdftool of this checkout if it exists, else brdftool on
# PATH), BRDF_DEVICE, BRDF_JOBS, BRDF_LOG as in brdf-array.sbatch; BRDF_ARRAY_LIMIT=K runs at most K
# tasks at once (--array=0-(N-1)%K).
# Prints the job id. Rerunning the same command after failures recomputes only what is missing.
set -euo pipefail

usage() { echo "usage: $0 CATALOGUE OUTDIR [TASKS] [-- SBATCH_OPTION...]" >&2; exit 2; }
[[ $# -ge 2 ]] || usage
catalogue=$1 outdir=$2
shift 2
tasks=""
if [[ $# -gt 0 && $1 != "--" ]]; then tasks=$1; shift; fi
if [[ $# -gt 0 ]]; then [[ $1 == "--" ]] || usage; shift; fi
extra=("$@")

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
[[ -f $catalogue ]] || { echo "$0: $catalogue: no such file" >&2; exit 3; }
catalogue=$(realpath "$catalogue")
mkdir -p "$outdir/logs"
outdir=$(realpath "$outdir")

if [[ -z ${BRDFTOOL:-} ]]; then
    if [[ -x $here/../../build/bin/brdftool ]]; then BRDFTOOL=$(realpath "$here/../../build/bin/brdftool")
    else BRDFTOOL=$(command -v brdftool || true); fi
fi
[[ -n $BRDFTOOL && -x $BRDFTOOL ]] || { echo "$0: brdftool not found; set BRDFTOOL to its path on the shared filesystem" >&2; exit 3; }
export BRDFTOOL

materials=$(python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
print(len(d["materials"]) if isinstance(d, dict) and "materials" in d else 1)
' "$catalogue" 2>/dev/null || true)
if [[ -z $tasks ]]; then
    [[ -n $materials ]] || { echo "$0: cannot count the materials of $catalogue (python3?); give TASKS" >&2; exit 2; }
    tasks=$(( materials < 1000 ? materials : 1000 ))
fi
[[ $tasks =~ ^[1-9][0-9]*$ ]] || { echo "$0: TASKS must be a positive integer (got '$tasks')" >&2; exit 2; }
if [[ -n $materials ]] && (( tasks > materials )); then
    echo "$0: note: $tasks tasks for $materials materials; tasks $materials..$((tasks - 1)) will have nothing to do" >&2
fi

array="0-$((tasks - 1))"
[[ -n ${BRDF_ARRAY_LIMIT:-} ]] && array+="%$BRDF_ARRAY_LIMIT"

# The array's size is the shard count; BRDF_SHARDS is set too, so that resubmitting a few indices
# of this job by hand (scontrol requeue, or sbatch --array=3,7 with the same environment) keeps N.
export BRDF_SHARDS=$tasks
sbatch --parsable --array="$array" --output="$outdir/logs/brdf-%A_%a.log" "${extra[@]}" \
    "$here/brdf-array.sbatch" "$catalogue" "$outdir"
