"""Moving parts inside static anatomy (issue 29): the whole image and each moving part at its own level.

For each experiment (``src/nct/conf/experiment/``), background setting and seed, one ``nct`` run
(FBP and NeuralCT in the same process, nct.analysis.benchmarking). Read from each run's
metrics.json: whole-image median MSE, PSNR and SSIM over the frames for FBP and NCT, the NCT/FBP
MSE ratio, and the Dice of each moving part at its own level (``objects``: its container's level
plus half its own). Writes runs.csv and background.md (one row per run, then the median over seeds).

Run: python benchmarks/background.py [--experiments thorax] [--backgrounds image none] [--seeds 0 1 2 3 4]
     [--jobs 2] [--out DIR] [--resume] [--timeout S] [--override KEY=VALUE ...]
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from nct.analysis.benchmarking import QUIET, Job, benchmark_parser, run_jobs
from nct.run.tables import markdown_table, write_csv

# Which of metrics.json's own-level objects are the moving parts, by name (the experiments' comments).
MOVING = {"thorax": {"heart": 7, "pool": 8}, "nodule": {"nodule": 3}}
# K per background: with background=image K counts the moving parts; without, the experiment's own.
N_OBJECTS = {"thorax": {"image": 2, "none": 2}, "nodule": {"image": 1, "none": 3}}


def jobs(experiments: list[str], backgrounds: list[str], seeds: list[int], out: Path,
         extra: tuple[str, ...]) -> list[Job]:
    return [Job({"experiment": e, "background": b}, "nct", s,
                (f"experiment={e}", f"background={b}", f"data.n_objects={N_OBJECTS[e][b]}", *QUIET, *extra),
                out / f"{e}_{b}" / f"seed{s}")
            for e in experiments for b in backgrounds for s in seeds]


def row(job: Job) -> dict:
    """One run's figures from its metrics.json (NaN where the run left none)."""
    path = job.run_dir / "metrics.json"
    base = {**job.labels, "seed": job.seed}
    if not path.is_file():
        return base | {"status": "failed"}
    m = json.loads(path.read_text())
    fbp, nct = m["fbp"], m["nct"]
    out = base | {"status": "ok", "fbp_mse": fbp["median_mse"], "nct_mse": nct["median_mse"],
                  "mse_ratio": nct["median_mse"] / fbp["median_mse"], "fbp_psnr": fbp["median_psnr"],
                  "nct_psnr": nct["median_psnr"], "fbp_ssim": fbp["median_ssim"], "nct_ssim": nct["median_ssim"]}
    for name, k in MOVING[job.labels["experiment"]].items():
        out[f"fbp_{name}"] = fbp["objects"][k]["median_dice"]
        out[f"nct_{name}"] = nct["objects"][k]["median_dice"]
    return out | {"rung": m["selection"]["rung"], "wall_s": m["wall_time_s"]}


def medians(rows: list[dict]) -> list[dict]:
    """The median over seeds of every figure, per experiment and background."""
    keys = sorted({(r["experiment"], r["background"]) for r in rows})
    out = []
    for e, b in keys:
        mine = [r for r in rows if (r["experiment"], r["background"]) == (e, b) and r["status"] == "ok"]
        figures = [k for k in (mine[0] if mine else {}) if isinstance(mine[0][k], float)]
        out.append({"experiment": e, "background": b, "seeds": len(mine)}
                   | {k: float(np.median([r[k] for r in mine])) for k in figures})
    return out


def table(rows: list[dict]) -> str:
    """``rows`` as one markdown table over every key they hold."""
    header = list(dict.fromkeys(k for r in rows for k in r))
    return markdown_table(header, [[r.get(k) for k in header] for r in rows])


def main(argv: list[str] | None = None) -> None:
    parser = benchmark_parser("background", __doc__.split("\n")[0], "seed 0 of the thorax only",
                              "seeds (default 0 1 2 3 4)")
    parser.add_argument("--experiments", nargs="+", default=list(MOVING), choices=list(MOVING))
    parser.add_argument("--backgrounds", nargs="+", default=["image"], choices=["image", "none"])
    parser.add_argument("--override", action="append", default=[], help="an extra nct override (repeatable)")
    args = parser.parse_args(argv)
    seeds = [0] if args.quick else (args.seeds or [0, 1, 2, 3, 4])
    experiments = ["thorax"] if args.quick else args.experiments
    todo = jobs(experiments, args.backgrounds, seeds, args.out, tuple(args.override))
    run_jobs(todo, args.jobs, args.resume, args.timeout, args.threads)
    rows = [row(j) for j in todo]
    write_csv(rows, args.out / "runs.csv")
    lines = ["# Moving parts inside static anatomy", "", table(rows), "", "Median over seeds:", "", table(medians(rows)), ""]
    (args.out / "background.md").write_text("\n".join(lines))
    print(f"wrote {args.out / 'background.md'}")


if __name__ == "__main__":
    main()
