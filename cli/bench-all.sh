#!/usr/bin/env bash
# Rerun every kept benchmark run and regenerate the report from them:
# docs/bench/runs/*.jsonl, docs/bench/ (report.md, SVG charts) and
# BENCHMARKS.md. Design and decisions: docs/benchmarking.md.
#
#   bash cli/bench-all.sh                          # the protocol: 1024x1024, 5 reps
#   SIZE=256x256 LABEL="loaded VM" bash cli/bench-all.sh
#
# Needs Embree 3 (`apt-get install libembree-dev`) and the shared scenes
# (PACKTRACE_SCENES, default ../shared/scenes). Every figure is one process
# on one core; run it on an otherwise idle machine, and say so in LABEL.
# Variables: SIZE, REPS, LABEL, SCENES (names of SCENE.obj files), ACCELS,
# THREADS (the second thread count of the scaling run), FEATURES (add
# tinybvh to trace tinybvh too: it needs g++ and RUSTFLAGS="-C target-cpu=native").
set -euo pipefail
cd "$(dirname "$0")/.."

scenes_dir=${PACKTRACE_SCENES:-../shared/scenes}
size=${SIZE:-1024x1024}
reps=${REPS:-5}
label=${LABEL:-}
features=${FEATURES:-embree}
accels=${ACCELS:-kd8,bvh8,embree,embree-coherent,obvhs}
threads=${THREADS:-2}
runs=docs/bench/runs

cargo build --release -p packtrace-cli --features "$features" --bin bench
bench=target/release/bench
label_args=()
[ -n "$label" ] && label_args=(--label "$label")

mkdir -p "$runs"
rm -f "$runs"/*.jsonl
# Every engine and mode on each scene, checked against scalar kd8 first.
for s in ${SCENES:-cornell_box teapot bunny sponza}; do
  "$bench" --scene "$scenes_dir/$s.obj" --accel "$accels" --size "$size" --reps "$reps" \
    --check "${label_args[@]}" --json "$runs/$s.jsonl" > /dev/null
done
# Thread scaling: the bunny again on more threads (the 1-thread lines are above).
"$bench" --scene "$scenes_dir/bunny.obj" --accel "$accels" --threads "$threads" \
  --workloads primary,ao --size "$size" --reps "$reps" "${label_args[@]}" \
  --json "$runs/bunny-threads.jsonl" > /dev/null

"$bench" report "$runs"/*.jsonl --out docs/bench --index BENCHMARKS.md
