"""Fan beam (issue 11): the circle experiment as fan-beam sinogram files, reconstructed by ``nct data=file``.

The scene is the circle experiment's (a disc of radius 0.15 on an orbit of radius 0.2 in a unit
field of view, 100 degrees of arc per gantry rotation, one rotation). This script writes it, for
each geometry below, as a sinogram file by its own analytic simulation (exact disc chords along
rays built from the documented convention, SUB_RAYS rays per bin, each view at its own time; it
imports nothing of nct's simulation or geometry), then runs the default ``nct data=file`` on each
file and seed (nct.analysis.benchmarking: a process per run). A run scores NeuralCT and the project's
fan-beam FBP (rebinned to parallel rays, 180-degree windows) on the same truth; the criterion of
issue 11 is NCT median Dice >= 0.93 and >= FBP's + 0.08.

Writes fan.csv (per geometry) and runs.csv, and fan.md with the command at the top, into
benchmarks/results/fan/ (with --quick: into --out, beside the runs and files).
Run: python benchmarks/fan.py [--size 128] [--seeds 0 1 2] [--jobs 2] [--quick] [--out DIR] [--resume]
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nct.analysis.benchmark_stats import group, median_ok, seed_stats
from nct.analysis.benchmarking import QUIET, Job, Record, benchmark_parser, companion, positive_int, run_jobs
from nct.run.tables import markdown_table, write_csv

RADIUS, ORBIT, DEG_PER_ROTATION = 0.15, 0.20, 100.0
ROTATION_TIME = 0.25  # s
SOURCE_DISTANCE, DETECTOR_DISTANCE = 2.0, 2.0  # unit field of view
OFFSET_BINS = 8  # the offset detector is shifted by this many bins and widened by twice as many
SUB_RAYS = 8
SUPERSAMPLE = 4
FULL = dict(size=128, views=720, frames=36, seeds=[0, 1, 2])
QUICK = dict(size=24, views=48, frames=4, seeds=[0])
QUICK_OVERRIDES = ("optim.init_steps=5", "optim.fit_steps=5", "optim.refine=false", "init.frames_per_rotation=8")
NCT_DICE, MARGIN = 0.93, 0.08  # issue 11's criterion
RESULTS = Path(__file__).resolve().parent / "results" / "fan"


@dataclass(frozen=True)
class Detector:
    """A fan-beam detector in the sinogram file's keys (unit field of view)."""

    name: str
    shape: str
    n_bins: int
    bin_spacing: float
    offset: float

    def u(self, sub_rays: int = 1) -> np.ndarray:
        """Detector coordinates of ``sub_rays`` rays evenly across every bin: [n_bins * sub_rays]."""
        centres = (np.arange(self.n_bins) - (self.n_bins - 1) / 2) * self.bin_spacing + self.offset
        sub = ((np.arange(sub_rays) + 0.5) / sub_rays - 0.5) * self.bin_spacing
        return (centres[:, None] + sub[None, :]).ravel()


def detectors(size: int) -> list[Detector]:
    """Flat, curved and offset flat detectors of ``size`` bins spanning the fan through the inscribed disc."""
    gamma = math.asin(0.5 / SOURCE_DISTANCE)  # the edge ray grazes the disc of radius 0.5
    total = SOURCE_DISTANCE + DETECTOR_DISTANCE
    flat, curved = 2 * total * math.tan(gamma) / size, 2 * total * gamma / size
    return [Detector("flat", "flat", size, flat, 0.0), Detector("curved", "curved", size, curved, 0.0),
            Detector("flat-offset", "flat", size + 2 * OFFSET_BINS, flat, OFFSET_BINS * flat)]


def disc_centres(times: np.ndarray) -> np.ndarray:
    """The disc's centre at ``times`` (s): [T, 2], on its orbit from angle 0, counter-clockwise."""
    phase = np.radians(DEG_PER_ROTATION) * times / ROTATION_TIME
    return ORBIT * np.stack((np.cos(phase), np.sin(phase)), -1)


def line_integrals(det: Detector, angles: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Exact disc chords along the fan rays, each view at its own time, averaged over SUB_RAYS rays per
    bin: [V, n_bins]. A ray leaves the source −D·d towards the flat detector point D_d·d + u·e (curved:
    at fan angle u / (D + D_d)); its distance from the disc's centre c is |(c + D·d) × w| for its unit
    direction w."""
    d = np.stack((-np.sin(angles), np.cos(angles)), -1)[:, None, :]
    e = np.stack((np.cos(angles), np.sin(angles)), -1)[:, None, :]
    u = det.u(SUB_RAYS)[None, :, None]
    total = SOURCE_DISTANCE + DETECTOR_DISTANCE
    if det.shape == "flat":
        w = (total * d + u * e) / np.sqrt(total**2 + u**2)
    else:
        w = np.cos(u / total) * d + np.sin(u / total) * e
    rel = disc_centres(times)[:, None, :] + SOURCE_DISTANCE * d
    distance = np.abs(rel[..., 0] * w[..., 1] - rel[..., 1] * w[..., 0])
    chords = 2 * np.sqrt(np.clip(RADIUS**2 - distance**2, 0.0, None))
    return chords.reshape(len(angles), det.n_bins, SUB_RAYS).mean(axis=-1)


def truth_frames(times: np.ndarray, size: int) -> np.ndarray:
    """The disc (intensity 1) on a ``size``² unit grid, rows down y, SUPERSAMPLE² points a pixel: [F, size, size]."""
    fine = size * SUPERSAMPLE
    c = (np.arange(fine) + 0.5) / fine - 0.5
    x, y = np.meshgrid(c, c[::-1])
    frames = np.stack([(x - cx) ** 2 + (y - cy) ** 2 <= RADIUS**2 for cx, cy in disc_centres(times)]).astype(float)
    return frames.reshape(len(times), size, SUPERSAMPLE, size, SUPERSAMPLE).mean(axis=(2, 4)).astype(np.float32)


def write_file(det: Detector, path: Path, size: int, views: int, frames: int) -> Path:
    """One rotation of ``views`` views of the scene as a fan-beam sinogram file with its truth."""
    angles = 2 * np.pi * np.arange(views) / views
    times = ROTATION_TIME * np.arange(views) / views
    truth_times = (np.arange(frames) + 0.5) * ROTATION_TIME / frames
    truth = truth_frames(truth_times, size)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, sinogram=line_integrals(det, angles, times).astype(np.float32), angles=angles,
                        times=times, bin_spacing=np.float64(det.bin_spacing), detector_offset=np.float64(det.offset),
                        source_distance=np.float64(SOURCE_DISTANCE), detector_distance=np.float64(DETECTOR_DISTANCE),
                        detector_shape=np.str_(det.shape), truth=truth, truth_times=truth_times,
                        truth_extent=np.float64(1.0), truth_level=np.float64(0.5 * truth.max()))
    return path


def plan(out: Path, files: dict[str, Path], seeds: Sequence[int], extra: Sequence[str]) -> list[Job]:
    """A default ``nct data=file`` run per geometry and seed in ``out/runs/<geometry>/seed<s>``."""
    return [Job({"geometry": name}, "nct", seed, ("data=file", f"data.path={path}", *QUIET, *extra),
                out / "runs" / name / f"seed{seed}")
            for name, path in files.items() for seed in seeds]


def summary(records: Sequence[Record]) -> list[dict]:
    """Per geometry: median over seeds of NCT's and FBP's median Dice (failures 0), margin, criterion."""
    rows = []
    for (name,), recs in group(records, ("geometry",)).items():
        nct, fbp = seed_stats(recs), seed_stats([companion(r, "fbp") for r in recs])
        margin = nct.median - fbp.median
        rows.append({"geometry": name, "nct_dice": nct.median, "nct_dice_min": nct.min, "fbp_dice": fbp.median,
                     "margin": margin, "nct_failed": nct.n_failed, "runs": nct.n,
                     "run_time_s": median_ok(recs, "run_time_s"),
                     "passed": nct.median >= NCT_DICE and margin >= MARGIN})
    return rows


def write_report(report: Path, records: Sequence[Record], command: str, elapsed_s: float, size: int) -> None:
    """fan.csv, runs.csv and fan.md (the command at the top) in ``report``."""
    rows = summary(records)
    write_csv(rows, report / "fan.csv")
    write_csv([r.row() for r in records], report / "runs.csv")
    seeds = " ".join(str(s) for s in sorted({r.job.seed for r in records}))
    text = "\n".join([
        "# Fan beam: circle at 100 deg/rotation (issue 11)", "",
        f"Command: `{command}` ({elapsed_s / 60:.1f} min; {size}-pixel truth, {size}-bin detectors, seeds {seeds}).",
        "", f"Criterion: NCT median Dice >= {NCT_DICE} and >= FBP + {MARGIN} (median over seeds of each run's "
        "median over frames; a failed run scores 0). FBP: fan data rebinned to parallel rays, 180-degree windows.", "",
        markdown_table(["geometry", "NCT Dice", "NCT min", "FBP Dice", "margin", "failed", "run time [s]", "passed"],
                       [[r["geometry"], r["nct_dice"], r["nct_dice_min"], r["fbp_dice"], r["margin"],
                         f"{r['nct_failed']}/{r['runs']}", r["run_time_s"], "yes" if r["passed"] else "**no**"]
                        for r in rows]), ""])
    (report / "fan.md").write_text(text)


def main(argv: Sequence[str] | None = None) -> None:
    parser = benchmark_parser("fan", __doc__.split("\n\n")[0],
                              f"tiny sizes ({QUICK['size']} px, {QUICK['views']} views, 5-step fits): seconds",
                              f"default {' '.join(map(str, FULL['seeds']))} (--quick {QUICK['seeds'][0]})")
    parser.add_argument("--size", type=positive_int, help=f"truth pixels and detector bins (default {FULL['size']}; "
                        f"--quick {QUICK['size']})")
    args = parser.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    size = args.size or sizes["size"]
    start = time.perf_counter()
    files = {det.name: write_file(det, args.out / "files" / f"{det.name}.npz", size, sizes["views"], sizes["frames"])
             for det in detectors(size)}
    jobs = plan(args.out, files, args.seeds or sizes["seeds"], QUICK_OVERRIDES if args.quick else ())
    records = run_jobs(jobs, args.jobs, args.resume, args.timeout, args.threads)
    report = args.out if args.quick else RESULTS
    command = "python benchmarks/fan.py " + " ".join(sys.argv[1:] if argv is None else argv)
    write_report(report, records, command.strip(), time.perf_counter() - start, size)
    print((report / "fan.md").read_text())
    print(f"runs in {args.out}; report in {report}")


if __name__ == "__main__":
    main()
