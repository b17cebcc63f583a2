#!/usr/bin/env bash
# Paired A/B timing of two `bench` binaries (a change against its base):
# runs A, B, A, B, ... on one pinned core, each on every scene, and prints
# per scene and workload the median Mrays/s of each and the median of the
# paired ratios A/B with their range. Pairing keeps a ratio meaningful
# when the machine's speed drifts; a single ratio moves by 10-20 % on the
# 2-core VMs this project is measured on, so read medians of >= 3 pairs.
#
#   cp target/release/bench /tmp/bench-base       # build the base first
#   ... change, cargo build --release -p packtrace-cli --bin bench ...
#   bash cli/ab.sh /tmp/bench-ab target/release/bench /tmp/bench-base
#
# Variables: PAIRS (default 3), SCENES (names of SCENE.obj files, default
# "bunny sponza"), BENCH_ARGS (default: the 8-wide BVH's single rays, the
# four workloads, 1024x1024, 5 repetitions), CPU (the pinned core, 1).
# The JSON lines are kept in OUT.A.jsonl and OUT.B.jsonl, the benches'
# output in OUT.log. Needs python3.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 OUT BENCH_A BENCH_B" >&2; exit 2; }
out=$1
a=$2
b=$3
scenes_dir=${PACKTRACE_SCENES:-../shared/scenes}
pairs=${PAIRS:-3}
scenes=${SCENES:-bunny sponza}
cpu=${CPU:-1}
read -r -a args <<<"${BENCH_ARGS:---accel bvh8 --modes scalar --workloads primary,shadow,ao,random --size 1024x1024 --reps 5}"
rm -f "$out.A.jsonl" "$out.B.jsonl" "$out.log"
one=$(mktemp)
trap 'rm -f "$one"' EXIT
for _ in $(seq "$pairs"); do
  for s in $scenes; do
    for x in A B; do
      bin=$a
      [ "$x" = B ] && bin=$b
      taskset -c "$cpu" "$bin" --scene "$scenes_dir/$s.obj" "${args[@]}" --no-stats --json "$one" >>"$out.log" 2>&1
      cat "$one" >>"$out.$x.jsonl"
    done
  done
done
python3 - "$out" <<'PY'
import collections, json, statistics as st, sys
out = sys.argv[1]
runs = {x: collections.defaultdict(list) for x in "AB"}
for x in "AB":
    for line in open(f"{out}.{x}.jsonl"):
        if line.strip():
            r = json.loads(line)
            runs[x][(r["scene"], r["workload"], r["accel"], r["mode"])].append(r["mrays_per_s"])
print(f"{'scene':10} {'workload':8} {'line':14} {'A':>7} {'B':>7}  A/B median [range]")
for k in sorted(runs["A"]):
    a, b = runs["A"][k], runs["B"][k]
    ratios = [p / q for p, q in zip(a, b)]
    print(f"{k[0]:10} {k[1]:8} {k[2] + '/' + k[3]:14} {st.median(a):7.2f} {st.median(b):7.2f}"
          f"  {st.median(ratios):.3f} [{min(ratios):.3f}-{max(ratios):.3f}]")
PY
