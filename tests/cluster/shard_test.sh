#!/usr/bin/env bash
# Label "service", no Slurm: `brdftool compute --shard I/3` for I = 0, 1, 2 into one folder computes
# every material of the example catalogue exactly once (shard I takes materials k with k % 3 == I),
# the tables equal those of one unsharded run byte for byte, and a rerun of shard 1 skips everything.
#
#   shard_test.sh BRDFTOOL SOURCE_DIR
set -euo pipefail

fail() { echo "FAILED (shard): $*" >&2; exit 1; }
[[ $# -eq 2 ]] || { echo "usage: $0 BRDFTOOL SOURCE_DIR" >&2; exit 2; }
brdftool=$(realpath "$1")
source_dir=$(realpath "$2")
command -v python3 >/dev/null || { echo "SKIPPED (shard): needs python3"; exit 77; }

tmp=$(mktemp -d /tmp/brdf-shard.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

# The example catalogue at draft accuracy with an RGB spectrum (seconds, not minutes).
python3 - "$source_dir/examples/catalogue.json" "$tmp/catalogue.json" "$tmp/names" <<'EOF'
import json, sys
cat = json.load(open(sys.argv[1]))
cat.setdefault("defaults", {}).update({"accuracy": "draft", "spectrum": "rgb"})
for m in cat["materials"]:
    m.pop("accuracy", None); m.pop("spectrum", None)
json.dump(cat, open(sys.argv[2], "w"), indent=1)
open(sys.argv[3], "w").write("".join(m["name"] + "\n" for m in cat["materials"]))
EOF
mapfile -t names < "$tmp/names"
total=${#names[@]}

written=0
for i in 0 1 2; do
    BRDF_LOG=info "$brdftool" compute "$tmp/catalogue.json" -o "$tmp/sharded" --shard "$i/3" --device cpu 2>"$tmp/shard$i.err" \
        || { cat "$tmp/shard$i.err"; fail "shard $i/3 failed"; }
    # Shard i computed exactly the materials k with k % 3 == i, in catalogue order.
    expected=$(for k in "${!names[@]}"; do (( k % 3 == i )) && echo "${names[k]}"; done; true)
    got=$(sed -n 's/.*\] \(.*\) done in .*/\1/p' "$tmp/shard$i.err" | sort)
    [[ $got == "$(sort <<<"$expected")" ]] || { cat "$tmp/shard$i.err"; fail "shard $i/3 computed [$got], expected [$expected]"; }
    n=$(grep -c . <<<"$expected")
    grep -q "brdftool compute: $n materials, $n written, 0 up to date, 0 failed" "$tmp/shard$i.err" \
        || { cat "$tmp/shard$i.err"; fail "shard $i/3: expected $n materials written"; }
    written=$((written + n))
done
(( written == total )) || fail "the shards wrote $written materials, the catalogue has $total"

# Every material appears exactly once: one report, one .binary, one .exr per name, nothing else.
expected_files=$(for n in "${names[@]}"; do printf '%s\n' "$n.binary" "$n.exr" "$n.report.json"; done | sort)
[[ $(cd "$tmp/sharded" && ls -A1 | sort) == "$expected_files" ]] \
    || fail "sharded folder holds $(cd "$tmp/sharded" && ls -A | tr '\n' ' '), expected one of each table and report per material"

# One unsharded run: the same tables, byte for byte, and the same reports but for timings.
"$brdftool" compute "$tmp/catalogue.json" -o "$tmp/single" --device cpu 2>"$tmp/single.err" \
    || { cat "$tmp/single.err"; fail "unsharded run failed"; }
for n in "${names[@]}"; do
    for ext in binary exr; do
        cmp "$tmp/single/$n.$ext" "$tmp/sharded/$n.$ext" || fail "$n.$ext differs between the sharded and unsharded runs"
    done
    python3 - "$tmp/single/$n.report.json" "$tmp/sharded/$n.report.json" <<'EOF' || fail "$n.report.json differs beyond seconds/device"
import json, sys
def load(p):
    d = json.load(open(p)); d.pop("seconds", None); d.pop("device", None); return d
sys.exit(load(sys.argv[1]) != load(sys.argv[2]))
EOF
done

# A rerun of shard 1 finds everything up to date and touches nothing.
before=$(cd "$tmp/sharded" && stat -c '%n %Y %s %i' -- * | sort)
"$brdftool" compute "$tmp/catalogue.json" -o "$tmp/sharded" --shard 1/3 --device cpu 2>"$tmp/rerun.err" \
    || { cat "$tmp/rerun.err"; fail "rerun of shard 1/3 failed"; }
# (true: a loop whose last test is false would fail the pipe under pipefail.)
n1=$( (for k in "${!names[@]}"; do (( k % 3 == 1 )) && echo x; done; true) | wc -l)
grep -q "brdftool compute: $n1 materials, 0 written, $n1 up to date, 0 failed" "$tmp/rerun.err" \
    || { cat "$tmp/rerun.err"; fail "rerun of shard 1/3 did not report all $n1 materials up to date"; }
[[ $(cd "$tmp/sharded" && stat -c '%n %Y %s %i' -- * | sort) == "$before" ]] || fail "rerun of shard 1/3 rewrote files"
echo "shard: $total materials over 3 shards, each once; tables byte-identical to an unsharded run; rerun of shard 1: $n1 up to date"
