#!/usr/bin/env bash
# Label "cluster": a real single-node Slurm cluster on localhost runs the example catalogue as a
# job array of 3 tasks (tools/slurm/submit.sh + brdf-array.sbatch, this build's brdftool), and the
# outputs must be byte-identical to one local `brdftool compute` of the same catalogue.
#
#   slurm_array_test.sh BRDFTOOL SOURCE_DIR
#
# When it runs, and when it installs packages (exit 77 = skipped, with the reason on stdout):
#   BRDF_CLUSTER_TEST=0   always skipped.
#   BRDF_CLUSTER_TEST=1   may run `apt-get install slurmctld slurmd munge slurm-client` (Debian; root,
#                         network) when Slurm is missing. Also allowed when CI is set (CI=true, as
#                         GitHub/GitLab set it) and the test runs as root: a throwaway CI machine.
#   unset                 runs only if Slurm and munge are already installed; never installs.
# It needs root (slurmd launches the jobs). Everything it starts - munged, slurmctld, slurmd - runs
# from a temporary folder with its own munge key and socket, slurm.conf (via SLURM_CONF) and free
# ports, so a Slurm or munge already configured on the machine is neither used nor disturbed; the
# daemons are stopped (by their pids) and the folder removed at the end (BRDF_KEEP_TMP=1 keeps it).
# If Slurm is installed but the cluster does not come up (no root, a container that forbids
# something), the test is skipped with the daemons' logs.
set -euo pipefail

SKIP=77
skip() { echo "SKIPPED (cluster): $*"; exit $SKIP; }
fail() { echo "FAILED (cluster): $*" >&2; exit 1; }

[[ $# -eq 2 ]] || { echo "usage: $0 BRDFTOOL SOURCE_DIR" >&2; exit 2; }
brdftool=$(realpath "$1")
source_dir=$(realpath "$2")
[[ -x $brdftool ]] || fail "$brdftool is not executable"

case "${BRDF_CLUSTER_TEST:-}" in
    0) skip "BRDF_CLUSTER_TEST=0" ;;
    1) may_install=1 ;;
    "") may_install=0 ;;
    *) fail "BRDF_CLUSTER_TEST must be 0 or 1 (got '${BRDF_CLUSTER_TEST}')" ;;
esac
ci=${CI:-}
if [[ $may_install == 0 && -n $ci && $ci != false && $ci != 0 && $(id -u) == 0 ]]; then may_install=1; fi

[[ $(id -u) == 0 ]] || skip "needs root to run slurmd (run as root with BRDF_CLUSTER_TEST=1)"
command -v python3 >/dev/null || skip "needs python3 (catalogue overrides, report comparison)"

have_slurm() {
    local c
    for c in slurmctld slurmd munged sbatch squeue sinfo scontrol; do
        command -v "$c" >/dev/null || PATH=$PATH:/usr/sbin command -v "$c" >/dev/null || return 1
    done
}
export PATH=$PATH:/usr/sbin:/sbin
if ! have_slurm; then
    [[ $may_install == 1 ]] || skip "Slurm is not installed; set BRDF_CLUSTER_TEST=1 (as root, with network) to let this test apt-get install slurmctld slurmd munge slurm-client"
    command -v apt-get >/dev/null || skip "Slurm is not installed and there is no apt-get"
    echo "cluster: installing slurmctld slurmd munge slurm-client with apt-get"
    # Packages must not start their system services (no systemd here, and not what we want):
    # Debian's policy-rc.d convention, only for the install and only if there is none.
    made_policy=0
    if [[ ! -e /usr/sbin/policy-rc.d ]]; then
        printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d && chmod 755 /usr/sbin/policy-rc.d && made_policy=1
    fi
    apt_install() { DEBIAN_FRONTEND=noninteractive timeout 600 apt-get install -y -q --no-install-recommends slurmctld slurmd munge slurm-client; }
    ok=1
    apt_install >/tmp/brdf-cluster-apt.$$.log 2>&1 || { timeout 300 apt-get update -q >>/tmp/brdf-cluster-apt.$$.log 2>&1 && apt_install >>/tmp/brdf-cluster-apt.$$.log 2>&1; } || ok=0
    [[ $made_policy == 1 ]] && rm -f /usr/sbin/policy-rc.d
    if [[ $ok == 0 ]]; then
        tail -n 5 /tmp/brdf-cluster-apt.$$.log
        rm -f /tmp/brdf-cluster-apt.$$.log
        skip "apt-get install slurmctld slurmd munge failed (no network or no package source?)"
    fi
    rm -f /tmp/brdf-cluster-apt.$$.log
    have_slurm || skip "Slurm still missing after apt-get install"
fi

tmp=$(mktemp -d /tmp/brdf-slurm.XXXXXX)
chmod 755 "$tmp"
pids=()
jobid=""
cleanup() {
    local status=$?
    if [[ -n $jobid ]]; then scancel "$jobid" >/dev/null 2>&1 || true; fi
    # Stop what this test started, newest first, by pid; wait so that nothing outlives the test.
    local k
    for (( k = ${#pids[@]} - 1; k >= 0; k-- )); do kill "${pids[k]}" 2>/dev/null || true; done
    for (( k = ${#pids[@]} - 1; k >= 0; k-- )); do
        for _ in $(seq 50); do kill -0 "${pids[k]}" 2>/dev/null || break; sleep 0.1; done
        kill -9 "${pids[k]}" 2>/dev/null || true
    done
    if [[ ${BRDF_KEEP_TMP:-0} == 1 ]]; then echo "cluster: kept $tmp"; else rm -rf "$tmp"; fi
    exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

show_logs() {
    local f
    for f in "$tmp"/munge/munged.log "$tmp"/log/slurmctld.log "$tmp"/log/slurmd.log; do
        [[ -f $f ]] && { echo "--- $f (last lines)"; tail -n 25 "$f"; }
    done
    return 0
}

# --- munge: own key, socket and logs -----------------------------------------------------------
mkdir -p "$tmp/munge" "$tmp/log" "$tmp/state" "$tmp/spool" "$tmp/shared"
chmod 700 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge/munge.key"
socket=$tmp/munge/munge.sock
munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$socket" \
    --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" --seed-file="$tmp/munge/munged.seed" \
    >"$tmp/munge/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [[ -S $socket ]] && break; sleep 0.1; done
if ! munge -n -S "$socket" | unmunge -S "$socket" >/dev/null 2>&1; then
    cat "$tmp/munge/munged.out"; show_logs
    skip "munged did not start (see above)"
fi

# --- slurm.conf: one node, localhost, 2 CPUs, no cgroups, state in the temporary folder -------
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
mem_mb=$(awk '/MemTotal/ {print int($2 / 1024 / 2)}' /proc/meminfo)
cat > "$tmp/slurm.conf" <<EOF
ClusterName=brdftest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool/slurmd-%n
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd-%n.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MinJobAge=600
SlurmdTimeout=60
NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$tmp/slurm.conf
# The client commands must not pick up a site's defaults.
unset SBATCH_PARTITION SBATCH_ACCOUNT SLURM_JOB_ID SLURM_ARRAY_TASK_ID SBATCH_EXPORT 2>/dev/null || true

slurmctld -D -i -f "$tmp/slurm.conf" >"$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$tmp/slurm.conf" >"$tmp/log/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 120); do
    state=$(sinfo -h -n localhost -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.5
done
if [[ $state != idle ]]; then
    cat "$tmp/log/slurmctld.out" "$tmp/log/slurmd.out"; show_logs
    skip "the single-node Slurm cluster did not come up (node state '${state:-none}'; see above)"
fi
echo "cluster: slurmctld and slurmd up on ports $ctld_port/$slurmd_port ($(sinfo --version))"

# --- the catalogue, made fast: draft accuracy, RGB spectrum -----------------------------------
python3 - "$source_dir/examples/catalogue.json" "$tmp/shared/catalogue.json" <<'EOF'
import json, sys
cat = json.load(open(sys.argv[1]))
cat.setdefault("defaults", {}).update({"accuracy": "draft", "spectrum": "rgb"})
for m in cat["materials"]:
    m.pop("accuracy", None); m.pop("spectrum", None)
json.dump(cat, open(sys.argv[2], "w"), indent=1)
EOF
materials=$(python3 -c 'import json,sys; print(len(json.load(open(sys.argv[1]))["materials"]))' "$tmp/shared/catalogue.json")

# --- local reference run ----------------------------------------------------------------------
"$brdftool" compute "$tmp/shared/catalogue.json" -o "$tmp/local" --device cpu --jobs 2 2>"$tmp/local.err" \
    || { cat "$tmp/local.err"; fail "local brdftool compute failed"; }

# --- the job array: 3 tasks, 1 CPU each (two run at once on this 2-CPU node) -------------------
out=$tmp/shared/out
jobid=$(BRDFTOOL=$brdftool BRDF_DEVICE=cpu "$source_dir/tools/slurm/submit.sh" "$tmp/shared/catalogue.json" "$out" 3 \
    -- --cpus-per-task=1 --mem-per-cpu=1G --time=30:00 --chdir="$tmp") \
    || { show_logs; fail "submit.sh failed"; }
jobid=${jobid%%;*}
echo "cluster: submitted job array $jobid (3 tasks)"
deadline=$(( SECONDS + ${BRDF_CLUSTER_TIMEOUT:-1200} ))
while [[ -n $(squeue -h -j "$jobid" -o %i 2>/dev/null) ]]; do
    (( SECONDS < deadline )) || { squeue -j "$jobid"; show_logs; fail "job array $jobid did not finish in time"; }
    sleep 2
done
for f in "$out"/logs/*.log; do echo "--- $f"; cat "$f"; done

# Every array task completed with exit code 0 (the job records stay for MinJobAge).
tasks=$(scontrol -o show job "$jobid" | sed -n 's/.*ArrayTaskId=\([0-9]*\) .*JobState=\([A-Z_]*\) .*ExitCode=\([0-9:]*\) .*/\1 \2 \3/p' | sort -n)
echo "cluster: array tasks (index state exit):"; echo "$tasks"
[[ $(echo "$tasks" | grep -c ' COMPLETED 0:0$') == 3 ]] || { show_logs; fail "not every array task completed with exit code 0"; }
for i in 0 1 2; do
    grep -q "shard $i/3 exit 0" "$out"/logs/brdf-"${jobid}"_"$i".log || fail "task $i's log does not show 'shard $i/3 exit 0'"
done

# --- byte identity with the local run ---------------------------------------------------------
compare() { # local and cluster folders hold the same tables, byte for byte, and the same reports
    local a=$1 b=$2 n=0 f
    diff <(cd "$a" && ls -A1 -I logs | sort) <(cd "$b" && ls -A1 -I logs | sort) \
        || fail "the output files differ between $a and $b"
    for f in "$a"/*.binary "$a"/*.exr; do
        cmp "$f" "$b/$(basename "$f")" || fail "$(basename "$f") differs"
        n=$((n + 1))
    done
    for f in "$a"/*.report.json; do
        python3 - "$f" "$b/$(basename "$f")" <<'EOF' || fail "$(basename "$f") differs (beyond seconds and device)"
import json, sys
def load(p):
    d = json.load(open(p)); d.pop("seconds", None); d.pop("device", None); return d
a, b = load(sys.argv[1]), load(sys.argv[2])
if a != b:
    print("report differs:", sys.argv[2], sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k)), file=sys.stderr)
    sys.exit(1)
EOF
    done
    echo "$n"
}
[[ $(ls "$tmp/local"/*.report.json | wc -l) == "$materials" ]] || fail "the local run did not write $materials reports"
tables=$(compare "$tmp/local" "$out")
echo "cluster: $materials materials, $tables tables byte-identical to the local run, reports equal but for seconds/device"
