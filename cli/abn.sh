#!/usr/bin/env bash
# Interleaved timing of several `bench` binaries (variants of one change):
# in every round each binary runs every case on one pinned core, in the
# order given on odd rounds and reversed on even ones, so that a drift of
# the machine's speed within a round favours none. Prints per case the
# first binary's median Mrays/s and, for every other binary, the median of
# its per-round ratio to the first with their range. On the 2-core VMs
# this project is measured on, one ratio moves by 20-40 %: read medians of
# >= 6 rounds, and only effects larger than their spread.
#
#   bash cli/abn.sh OUT ROUNDS BENCH_BASE BENCH_X [BENCH_Y ...]
#
# Variables: CASES (scene:workload pairs, default "bunny:random
# sponza:ao bunny:ao sponza:random"), BENCH_ARGS (default: the kd-tree's
# stream, 1024x1024, 3 repetitions), CPU (the pinned core, 1). Binaries are
# named by their file names (which must differ). JSON lines go to OUT.jsonl.
# Needs python3.
set -euo pipefail
[ $# -ge 4 ] || { echo "usage: $0 OUT ROUNDS BENCH_BASE BENCH_X [BENCH_Y ...]" >&2; exit 2; }
out=$1
rounds=$2
shift 2
bins=("$@")
scenes_dir=${PACKTRACE_SCENES:-../shared/scenes}
cases=${CASES:-bunny:random sponza:ao bunny:ao sponza:random}
cpu=${CPU:-1}
read -r -a args <<<"${BENCH_ARGS:---accel kd8 --modes stream --size 1024x1024 --reps 3}"
rm -f "$out.jsonl"
one=$(mktemp)
trap 'rm -f "$one"' EXIT
for r in $(seq "$rounds"); do
  order=("${bins[@]}")
  if [ $((r % 2)) = 0 ]; then
    order=()
    for ((k = ${#bins[@]} - 1; k >= 0; k--)); do order+=("${bins[k]}"); done
  fi
  for bin in "${order[@]}"; do
    for c in $cases; do
      taskset -c "$cpu" "$bin" --scene "$scenes_dir/${c%%:*}.obj" "${args[@]}" --workloads "${c##*:}" \
        --no-stats --label "$(basename "$bin")@$r" --json "$one" >/dev/null 2>&1
      cat "$one" >>"$out.jsonl"
    done
  done
done
python3 - "$out.jsonl" "$(basename "${bins[0]}")" <<'PY'
import collections, json, statistics as st, sys
path, base = sys.argv[1], sys.argv[2]
runs = collections.defaultdict(dict)
names = []
for line in open(path):
    j = json.loads(line)
    name, r = j["label"].rsplit("@", 1)
    if name not in names:
        names.append(name)
    runs[(j["scene"], j["workload"], j["mode"], r)][name] = j["mrays_per_s"]
rows = collections.defaultdict(lambda: collections.defaultdict(list))
for (scene, w, mode, _), v in runs.items():
    if base not in v:
        continue
    rows[(scene, w, mode)][base + " Mrays/s"].append(v[base])
    for n in names:
        if n != base and n in v:
            rows[(scene, w, mode)][n].append(v[n] / v[base])
print(f"{'scene':10} {'workload':8} {'mode':8} {base + ' Mrays/s':>18}  " + "  ".join(f"{n + '/' + base:>24}" for n in names if n != base))
for k in sorted(rows):
    v = rows[k]
    cells = [f"{st.median(v[n]):.3f} [{min(v[n]):.2f}-{max(v[n]):.2f}]" for n in names if n != base]
    print(f"{k[0]:10} {k[1]:8} {k[2]:8} {st.median(v[base + ' Mrays/s']):18.2f}  " + "  ".join(f"{c:>24}" for c in cells))
PY
