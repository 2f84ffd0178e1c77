#!/usr/bin/env bash
# The checks a CUDA machine adds to the CPU test run (README, "Testing"), with their logs in OUTDIR:
#   1. the tests marked `gpu` (CUDA runs in f32 compared with the CPU's; f64 is refused on CUDA,
#      docs/decisions.md "CUDA and f64");
#   2. `main.py bench --scenes --arch cuda` over the first 61 frames, scene by scene (each log
#      survives a time limit).
# Every step stops at the deadline, so the script ends within TOTAL_SECONDS.
# Usage: tools/gpu_check.sh OUTDIR [TOTAL_SECONDS] [SCENES]   (SCENES: comma-separated, default pot,glass_r3,pots)
set -u
out=${1:?usage: tools/gpu_check.sh OUTDIR [TOTAL_SECONDS] [SCENES]}
deadline=$((SECONDS + ${2:-540}))
scenes=${3:-pot,glass_r3,pots}
py=${PYTHON:-python3}
cd "$(dirname "$0")/.."
mkdir -p "$out"

{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; nproc; $py --version; } >"$out/machine.txt" 2>&1
cat "$out/machine.txt"
# only the files that hold gpu tests: collecting the others imports packages a GPU image may lack
gpu_files=$(grep -rl --include='test_*.py' 'mark.gpu' tests)
timeout $((deadline - SECONDS)) $py -m pytest --arch cuda -m gpu -q -rfE -p no:cacheprovider $gpu_files >"$out/pytest_gpu.txt" 2>&1
echo "pytest --arch cuda -m gpu: exit $?"
tail -n 5 "$out/pytest_gpu.txt"
for scene in ${scenes//,/ }; do
    budget=$((deadline - SECONDS))
    if [ "$budget" -lt 20 ]; then echo "bench $scene: not run (deadline)"; continue; fi
    timeout "$budget" $py main.py bench --scenes --arch cuda --only "$scene" --frames 61 >"$out/bench_$scene.txt" 2>&1
    echo "bench $scene: exit $?"
    grep -E "^\| $scene |^Measured" "$out/bench_$scene.txt"
done
