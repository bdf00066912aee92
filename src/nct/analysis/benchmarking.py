"""Benchmark harness: each configuration runs in a fresh ``nct`` process and is measured alone.

Shared by ``benchmarks/speed_accuracy.py`` and ``benchmarks/stability.py``. A job is
``python -m nct.cli.main <overrides> seed=<s> hydra.run.dir=<dir>``; its wall time and peak memory are
the child's own (``os.wait4`` rusage), its scores come from the run folder (docs/ARCHITECTURE.md).
A run that failed, diverged, timed out or scored NaN is a failure, never a result (what the benchmarks
make of the records: ``benchmark_stats.py``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from nct.records import write_json
from nct.run.outcome import FINISHED, UNFINISHED, read_outcome

BENCH_FILE = "bench.json"
RETRIED = ("failed", "timeout")  # statuses that ``resume`` runs again (crashes, not the method's own verdict)
LOG_FILE = "bench.log"
QUIET = ("logger=none", "export.tiff=false", "export.png=false", "export.gif=false")


@dataclass(frozen=True)
class Job:
    """One run to do. ``labels``: what names it in tables (e.g. scene, config); ``method``: fbp | nct,
    the summary of metrics.json that scores it; ``overrides``: the ``nct`` command-line overrides."""

    labels: dict
    method: str
    seed: int
    overrides: tuple[str, ...]
    run_dir: Path

    def __post_init__(self) -> None:
        if self.method not in ("fbp", "nct"):
            raise ValueError(f"Job.method must be 'fbp' or 'nct', got {self.method!r}")

    def command(self) -> list[str]:
        """The child's command line (``method=fbp`` added for FBP jobs)."""
        method = ("method=fbp",) if self.method == "fbp" else ()
        return [sys.executable, "-m", "nct.cli.main", *self.overrides, *method, f"seed={self.seed}",
                f"hydra.run.dir={self.run_dir}"]


@dataclass
class Record:
    """What one job gave.

    status: ok | failed | diverged | timeout | invalid (NaN scores) | running (killed mid-run).
    wall_time_s: the whole process (start-up included); run_time_s: the job's own wall time, from the
    process's start to its outputs written (metrics.json ``wall_time_s``). peak_mem_mib: the child's
    peak resident memory. n_params: from metrics.json ``model.n_params`` (0 for FBP, NaN when the
    method does not report it).
    dice, mse: medians over the run's frames. stages: metrics.json ``stages`` (per stage steps, time).
    """

    job: Job
    status: str
    error: str | None = None
    threads: int = 1
    wall_time_s: float = math.nan
    run_time_s: float = math.nan
    peak_mem_mib: float = math.nan
    n_params: float = math.nan
    dice: float = math.nan
    mse: float = math.nan
    stages: dict = field(default_factory=dict)
    model: dict = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        return self.status != "ok"

    def row(self) -> dict:
        """A flat CSV row: the job's labels, then the measurements."""
        return {**self.job.labels, "method": self.job.method, "seed": self.job.seed, "status": self.status,
                "wall_time_s": self.wall_time_s, "run_time_s": self.run_time_s, "threads": self.threads,
                "peak_mem_mib": self.peak_mem_mib, "n_params": self.n_params, "dice_median": self.dice,
                "mse_median": self.mse, "error": self.error or "", "run_dir": str(self.job.run_dir),
                "overrides": " ".join(self.job.overrides)}


def read_run(run_dir: Path, method: str) -> dict:
    """Status, error and scores of a finished run folder (`read_outcome`), as `Record` fields; a run
    that left no readable status.json failed, with the end of its log as the error."""
    outcome = read_outcome(run_dir)
    if outcome.status == UNFINISHED:
        return {"status": "failed", "error": _log_error(run_dir / LOG_FILE) or outcome.error}
    if outcome.status != FINISHED:
        return {"status": outcome.status, "error": outcome.error}
    metrics = outcome.metrics
    if metrics is None:
        return {"status": "invalid", "error": outcome.error}
    summary = metrics.get(method)
    if summary is None:
        return {"status": "invalid", "error": f"metrics.json has no '{method}' summary (no ground truth?)"}
    out = {"status": "ok", "error": None, "run_time_s": float(metrics.get("wall_time_s", math.nan)),
           "dice": float(summary["median_dice"]), "mse": float(summary["median_mse"]),
           "stages": metrics.get("stages") or {}, "model": metrics.get("model") or {},
           "n_params": 0.0 if method == "fbp" else float((metrics.get("model") or {}).get("n_params", math.nan))}
    if not (math.isfinite(out["dice"]) and math.isfinite(out["mse"])):
        out.update(status="invalid", error=f"non-finite scores: Dice {out['dice']}, MSE {out['mse']}")
    return out


def _log_error(path: Path) -> str | None:
    """The last two unindented lines of a run's log, without Hydra's hint about HYDRA_FULL_ERROR."""
    text = path.read_text(errors="replace") if path.is_file() else ""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln[0].isspace() and "HYDRA_FULL_ERROR" not in ln]
    return " / ".join(lines[-2:]) or None


def companion(record: Record, method: str) -> Record:
    """The record of ``method`` as scored inside ``record``'s run (a NeuralCT run scores FBP too): its
    status and scores from the same folder, the process's times left NaN (they are the other method's)."""
    job = Job(record.job.labels, method, record.job.seed, record.job.overrides, record.job.run_dir)
    fields = read_run(record.job.run_dir, method)
    fields.pop("run_time_s", None)
    return Record(job=job, threads=record.threads, **fields)


def run_one(job: Job, threads: int = 1, timeout_s: float | None = None) -> Record:
    """Run ``job`` in a fresh process with ``threads`` BLAS/OpenMP threads; kill it after ``timeout_s``."""
    job.run_dir.mkdir(parents=True, exist_ok=True)
    env = os.environ | {"OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)}
    with open(job.run_dir / LOG_FILE, "w") as log:
        start = time.perf_counter()
        proc = subprocess.Popen(job.command(), stdout=log, stderr=subprocess.STDOUT, env=env)
        timer = threading.Timer(timeout_s, proc.kill) if timeout_s else None
        if timer:
            timer.start()
        _, wait_status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        if timer:
            timer.cancel()
    proc.returncode = os.waitstatus_to_exitcode(wait_status)
    fields = read_run(job.run_dir, job.method)
    timed_out = timeout_s is not None and wall >= timeout_s and proc.returncode < 0
    if timed_out:
        fields.update(status="timeout", error=f"killed after {timeout_s:g} s")
    elif proc.returncode != 0 and fields["status"] in ("ok", "running"):
        fields.update(status="failed", error=f"exit code {proc.returncode}: {_log_error(job.run_dir / LOG_FILE)}")
    record = Record(job=job, threads=threads, wall_time_s=wall, peak_mem_mib=usage.ru_maxrss / 1024, **fields)
    save_record(record)
    return record


def save_record(record: Record) -> None:
    """Write the record's measurements to ``<run_dir>/bench.json`` (for ``resume``)."""
    payload = {k: v for k, v in asdict(record).items() if k != "job"}
    write_json(record.job.run_dir / BENCH_FILE, payload, indent=1)


def load_record(job: Job) -> Record | None:
    """The record a previous benchmark left in ``job.run_dir``, or None."""
    path = job.run_dir / BENCH_FILE
    return Record(job=job, **json.loads(path.read_text())) if path.is_file() else None


def run_jobs(jobs: Sequence[Job], n_jobs: int = 1, resume: bool = False, timeout_s: float | None = None,
             threads: int = 1, progress: Callable[[str], None] = print) -> list[Record]:
    """Run ``jobs``, ``n_jobs`` at a time, each with ``threads`` threads; records in job order.

    One thread is the default: on a shared CPU, a second OpenMP thread that has to wait for a busy
    core slowed a NeuralCT run up to 20-fold (benchmarks/README.md). ``resume``: a job whose folder
    holds a record is not run again unless it failed or timed out (diverged and NaN runs are kept); one run
    again starts in an emptied folder (nct never replaces the run a folder holds).
    """
    if n_jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {n_jobs}")
    if threads < 1:
        raise ValueError(f"--threads must be >= 1, got {threads}")
    started = [j.run_dir for j in jobs if (j.run_dir / "status.json").exists()]
    if started and not resume:
        raise ValueError(f"{started[0].parent} already holds runs ({len(started)} of these jobs): "
                         "pass --resume to keep the finished ones, or choose another --out")
    done = [0]
    lock = threading.Lock()

    def one(job: Job) -> Record:
        record = load_record(job) if resume else None
        kept = record is not None and record.status not in RETRIED
        if not kept:
            shutil.rmtree(job.run_dir, ignore_errors=True)  # a failed, timed-out or killed run of this job
            record = run_one(job, threads, timeout_s)
        with lock:
            done[0] += 1
            progress(f"[{done[0]}/{len(jobs)}] {describe(record)}{' (kept from an earlier call)' if kept else ''}")
        return record

    with ThreadPoolExecutor(n_jobs) as pool:
        return list(pool.map(one, jobs))


def describe(record: Record) -> str:
    """One line: labels, seed, status, Dice and time."""
    labels = " ".join(f"{v}" for v in record.job.labels.values())
    score = f"Dice {record.dice:.3f}" if not record.failed else f"{record.status}: {record.error}"
    return f"{labels} {record.job.method} seed {record.job.seed}: {score} ({record.wall_time_s:.1f} s)"


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def benchmark_parser(name: str, description: str, quick: str, seeds: str | None) -> argparse.ArgumentParser:
    """The options the benchmarks share: --out, --quick, --seeds (unless ``seeds`` is None: a benchmark
    that does not repeat runs over seeds), --jobs, --threads, --resume, --timeout."""
    parser = argparse.ArgumentParser(description=description)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    parser.add_argument("--out", type=Path, default=Path(f"outputs/benchmarks/{name}-{stamp}"),
                        help="output folder (default outputs/benchmarks/<name>-<date and time>)")
    parser.add_argument("--quick", action="store_true", help=quick)
    if seeds is not None:
        parser.add_argument("--seeds", type=int, nargs="+", help=seeds)
    parser.add_argument("--jobs", type=positive_int, default=1, help="runs at a time (default 1)")
    parser.add_argument("--threads", type=positive_int, default=1, help="OpenMP threads per run (default 1)")
    parser.add_argument("--resume", action="store_true",
                        help="keep the runs an earlier call finished in --out; run the rest and the failed ones")
    parser.add_argument("--timeout", type=float, help="seconds after which a run is killed and counted as failed")
    return parser


def default_config(overrides: Sequence[str] = ()) -> DictConfig:
    """The composed ``nct`` config, as ``nct --cfg job`` prints it, to read defaults such as step counts.

    Read in a child process so that this harness never imports torch: a child's peak memory
    (ru_maxrss) starts from the harness's resident size at spawn, which must stay small.
    """
    out = subprocess.run([sys.executable, "-m", "nct.cli.main", *overrides, "--cfg", "job"], capture_output=True,
                         text=True)
    if out.returncode != 0:
        raise ValueError(f"nct --cfg job {' '.join(overrides)} failed: {out.stderr.strip()}")
    return OmegaConf.create(out.stdout)


STAGE_STEPS = ("init_steps", "fit_steps", "refine_init_steps", "refine_fit_steps")
SCHEDULE_STEPS = ("warmup_steps", "lr_decay_every")


def stage_steps(defaults: DictConfig, steps: int) -> tuple[str, ...]:
    """Overrides giving every optimisation stage the configuration has (``STAGE_STEPS``) ``steps`` steps."""
    return tuple(f"optim.{k}={steps}" for k in STAGE_STEPS if k in defaults.optim)


def scaled_steps(defaults: DictConfig, factor: float) -> tuple[str, ...]:
    """Overrides scaling each stage's configured step count and the learning-rate schedule (warm-up,
    decay interval) of ``defaults.optim`` by ``factor``: the same recipe, compressed or stretched."""
    t = defaults.optim
    return tuple(f"optim.{k}={max(1, round(t[k] * factor))}" for k in STAGE_STEPS + SCHEDULE_STEPS if k in t)
