#!/bin/bash
# The checks a CUDA machine gets (one call, about 8 minutes on an H200 host with 16 cores):
#   1. the default run (circle, 100 deg/rot) with trainer=gpu, twice in turn on the idle host, then once
#      with motion=auto (each run's metrics.json holds its phases: where the time went);
#   2. then, side by side: the test suite with a CUDA device present (the device-fixture tests also run
#      on it), 4 workers; and a 128 px benchmark on the GPU, many runs at a time: BENCH=generalisation
#      (the 100 scenes, 10 at a time, until DEADLINE_S seconds after the start; continue it with
#      --resume) or BENCH=textured (the 9 textured scenes, all at once, each run stopped after RUN_S
#      seconds and scored as failed: the table is always written) with BACKGROUNDS (textured.py's
#      --backgrounds: auto is nothing about the scene passed).
# Run from the repository root with nct importable (pytest-xdist for -n):
#   bash benchmarks/gpu_check.sh OUT [DEADLINE_S [BENCH [RUN_S [BACKGROUNDS]]]]
#   (defaults 480, textured, 300, auto). Results: benchmarks/results/gpu/README.md.
out=${1:?usage: bash benchmarks/gpu_check.sh OUT [DEADLINE_S [BENCH [RUN_S [BACKGROUNDS]]]]}; deadline=${2:-480}
bench=${3:-textured}; run_s=${4:-300}; backgrounds=${5:-auto}; t0=$(date +%s)
case $bench in generalisation|textured) ;; *) echo "gpu_check: BENCH must be generalisation or textured, not $bench" >&2; exit 2 ;; esac
mkdir -p "$out" "$out/default"
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
python3 -c "import torch,lightning,hydra,numpy;print('torch',torch.__version__,'lightning',lightning.__version__,'hydra',hydra.__version__,'numpy',numpy.__version__,torch.cuda.get_device_name())" > "$out/env.txt" 2>&1
{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv; nproc; lscpu | grep "Model name"; } >> "$out/env.txt"
run() {  # NAME, then the command's overrides: one default run, its whole-process wall time in default.txt
  local name=$1; shift; local s; s=$(date +%s.%N)
  timeout 150 python3 -m nct.cli.main "$@" seed=0 hydra.run.dir="$out/default/$name" > "$out/default/$name.log" 2>&1
  echo "$name rc=$? wall=$(awk "BEGIN{print $(date +%s.%N) - $s}")" >> "$out/default.txt"
}
run gpu1 trainer=gpu
run gpu2 trainer=gpu
run gpu_auto trainer=gpu motion=auto
left=$(( deadline - ($(date +%s) - t0) ))
OMP_NUM_THREADS=1 timeout $left python3 -m pytest -q -n 4 -p no:cacheprovider tests > "$out/pytest.txt" 2>&1 &
tests_pid=$!
case $bench in
  generalisation) timeout $left python3 benchmarks/generalisation.py --scenes 100 --size 128 --jobs 10 \
    --threads 1 --override trainer=gpu --out "$out/generalisation" > "$out/generalisation.log" 2>&1 ;;
  textured) timeout $left python3 benchmarks/textured.py --scenes 3 --size 128 --jobs 9 --threads 1 \
    --backgrounds $backgrounds --timeout "$run_s" --override trainer=gpu --out "$out/textured" \
    > "$out/textured.log" 2>&1 ;;
esac
echo "$bench rc $? after $(( $(date +%s) - t0 )) s" >> "$out/default.txt"
wait $tests_pid; echo "pytest rc $? after $(( $(date +%s) - t0 )) s" >> "$out/default.txt"
cat "$out/default.txt"; tail -3 "$out/pytest.txt"
