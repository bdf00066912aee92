#!/bin/bash
# The checks a CUDA machine gets (one call, about 9 minutes on an H200 host with 16 cores):
#   1. the test suite with a CUDA device present (the device-fixture tests also run on it), 12 workers;
#   2. the default run (circle, 100 deg/rot) twice on the GPU and once on 2 of the host's cores;
#   3. the 128 px generalisation benchmark on the GPU, 12 runs at a time, until DEADLINE_S seconds
#      after the start (continue it anywhere with the same --out and --resume).
# Run from the repository root with nct importable (pytest-xdist for -n):
#   bash benchmarks/gpu_check.sh OUT [DEADLINE_S]   (default 555)
# Results: benchmarks/results/gpu/README.md.
out=${1:?usage: bash benchmarks/gpu_check.sh OUT [DEADLINE_S]}; deadline=${2:-555}; t0=$(date +%s)
mkdir -p "$out" "$out/default"
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
python3 -c "import torch,lightning,hydra,numpy;print('torch',torch.__version__,'lightning',lightning.__version__,'hydra',hydra.__version__,'numpy',numpy.__version__,torch.cuda.get_device_name())" > "$out/env.txt" 2>&1
{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv; nproc; lscpu | grep "Model name"; } >> "$out/env.txt"
OMP_NUM_THREADS=1 timeout 170 python3 -m pytest -q -n 12 -p no:cacheprovider tests > "$out/pytest.txt" 2>&1
echo "pytest rc $?" >> "$out/pytest.txt"
run() {  # NAME, then the command: one default run, its whole-process wall time in default.txt
  local name=$1; shift; local s; s=$(date +%s.%N)
  timeout 150 "$@" seed=0 hydra.run.dir="$out/default/$name" > "$out/default/$name.log" 2>&1
  echo "$name rc=$? wall=$(awk "BEGIN{print $(date +%s.%N) - $s}")" >> "$out/default.txt"
}
run gpu1 python3 -m nct.cli.main trainer=gpu
run gpu2 python3 -m nct.cli.main trainer=gpu
OMP_NUM_THREADS=2 run cpu2 taskset -c 2,3 python3 -m nct.cli.main trainer=cpu
timeout $(( deadline - ($(date +%s) - t0) )) python3 benchmarks/generalisation.py --scenes 100 --size 128 --jobs 12 \
  --threads 1 --override trainer=gpu --out "$out/generalisation" > "$out/generalisation.log" 2>&1
cat "$out/default.txt"; tail -3 "$out/pytest.txt"; grep -c Dice "$out/generalisation.log"
