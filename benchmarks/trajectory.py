"""What the data cannot tell (issue 27, items 3-4): the centroid trajectory of the project's circle
read off its sinogram (`nct.moments.trajectory`), against the truth, with the truth-free verdict.

For each speed (degrees of orbit per gantry rotation) and scan length (rotations), the circle
experiment (conf/phantom/circle.yaml, conf/scanner/parallel.yaml, conf/image/default.yaml) is
simulated analytically, its centroid trajectory fitted, and the table gives: the verdict's value
(the spread along the rays between equally good fits, pixels), the fit's largest and RMS distance
to the true centre over the views (pixels), and, for comparison, the largest error of a plain
least-squares Legendre polynomial (degree: the lowest whose misfit is within 1.5x of the best up
to degree 12). Also draws docs/figures/ambiguity.png: two trajectories, one sinogram.

Writes README.md (with the command) and trajectory.csv into benchmarks/results/trajectory/.
Run: python benchmarks/trajectory.py [--speeds 100 125 150 200 300] [--rotations 1 3] [--noise-i0 N]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from omegaconf import OmegaConf

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.moments.trajectory import centroid_projections, determinacy, fit_trajectory
from nct.run.tables import markdown_table, write_csv
from nct.scenes.phantoms import CircleConf, build_phantom
from nct.scenes.shapes import EllipsePhantom
from nct.scenes.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
CONF = ROOT / "src" / "nct" / "conf"
RESULTS = ROOT / "benchmarks" / "results" / "trajectory"
FIGURE = ROOT / "docs" / "figures" / "ambiguity.png"
MAX_DEGREE = 12


def setup(deg: float, rotations: float) -> tuple[CircleConf, Scanner, ImageGrid]:
    """The circle experiment at ``deg`` per rotation over ``rotations``, from the package's configs."""
    scanner, image = OmegaConf.load(CONF / "scanner" / "parallel.yaml"), OmegaConf.load(CONF / "image" / "default.yaml")
    circle = OmegaConf.load(CONF / "phantom" / "circle.yaml")
    grid = ImageGrid(int(image.size), float(image.extent))
    n_bins = int(scanner.n_bins)
    spacing = float(scanner.bin_spacing) if scanner.bin_spacing is not None else grid.extent / n_bins
    return (CircleConf(radius=circle.radius, orbit_radius=circle.orbit_radius, displacement_deg=deg,
                       start_deg=circle.start_deg, intensity=circle.intensity),
            Scanner(views_per_rotation=int(scanner.views_per_rotation), rotations=rotations,
                    rotation_time=float(scanner.rotation_time), start_angle=math.radians(scanner.start_deg),
                    n_bins=n_bins, bin_spacing=spacing),
            grid)


def legendre_error(angles: np.ndarray, p: np.ndarray, truth: np.ndarray) -> float:
    """Largest distance to ``truth`` [V, 2] of the least-squares Legendre fit of e(θ)·c(t) = p whose
    degree is the lowest with an RMS misfit within 1.5x of the best up to MAX_DEGREE."""
    x = 2 * (angles - angles[0]) / (angles[-1] - angles[0]) - 1
    e = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    fits = []
    for degree in range(MAX_DEGREE + 1):
        basis = np.polynomial.legendre.legvander(x, degree)
        design = np.concatenate([basis * e[:, :1], basis * e[:, 1:]], axis=1)
        coef = np.linalg.lstsq(design, p, rcond=None)[0]
        fits.append((float(np.sqrt(np.mean((design @ coef - p) ** 2))), basis @ coef.reshape(2, -1).T))
    best = min(misfit for misfit, _ in fits)
    centre = next(c for misfit, c in fits if misfit <= 1.5 * best)
    return float(np.linalg.norm(centre - truth, axis=1).max())


def measure(deg: float, rotations: float, noise_i0: float | None) -> dict[str, object]:
    """One row of the table: the circle at ``deg``/rot over ``rotations``."""
    conf, scanner, grid = setup(deg, rotations)
    phantom = build_phantom(conf, scanner.rotation_time)
    sino = simulate(phantom, scanner, grid, scanner.frame_times(1), noise_i0, np.random.default_rng(0))
    truth = phantom.ellipses(scanner.times, grid.extent)[:, 0, :2]
    start = time.perf_counter()
    p = centroid_projections(sino)
    trajectory = fit_trajectory(sino.angles, sino.times, p)
    verdict = determinacy(trajectory, sino.times, grid.pixel_size)
    seconds = time.perf_counter() - start
    error = np.linalg.norm(trajectory.at(sino.times) - truth, axis=1) / grid.pixel_size
    along = np.stack([np.cos(sino.angles), np.sin(sino.angles)], axis=1)
    return {"deg_per_rotation": deg, "rotations": rotations, "spread_px": verdict.value_px,
            "error_max_px": float(error.max()), "error_rms_px": float(np.sqrt(np.mean(error ** 2))),
            "determined": verdict.determined, "length_scale_rot": trajectory.length_scale,
            "centroid_error_px": float(np.abs(p - (along * truth).sum(axis=1)).max() / grid.pixel_size),
            "legendre_error_max_px": legendre_error(sino.angles, p, truth) / grid.pixel_size,
            "seconds": seconds}


def ambiguity_figure() -> tuple[Figure, float]:
    """Two trajectories, one sinogram: the circle at 100°/rot and c(t) + f(t)·d(θ(t)), both discs
    projected in closed form (`EllipsePhantom.project`); and the largest sinogram difference."""
    conf, scanner, grid = setup(100.0, 1.0)
    true = build_phantom(conf, scanner.rotation_time)

    def shifted(tau: np.ndarray) -> np.ndarray:
        params = true.ellipses(tau * scanner.rotation_time)
        theta = scanner.start_angle + 2 * math.pi * tau
        f = 0.12 * np.sin(math.pi * tau)  # FOV fractions: any f(t) at all gives the same disc sinogram
        params[:, 0, 0] -= f * np.sin(theta)
        params[:, 0, 1] += f * np.cos(theta)
        return params

    other = EllipsePhantom(shifted, true.intensities, scanner.rotation_time)
    sinos = [p.project(scanner, grid).astype(np.float64) for p in (true, other)]
    difference = float(np.abs(sinos[0] - sinos[1]).max())
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.8), constrained_layout=True)
    centres = [p.ellipses(scanner.times, grid.extent)[:, 0, :2] for p in (true, other)]
    for centre, label, colour in zip(centres, ("the circle's centre c(t)", "c(t) + f(t)·(−sin θ(t), cos θ(t))"),
                                     ("C0", "C3")):
        left.plot(centre[:, 0], centre[:, 1], color=colour, label=label)
        middle = len(centre) // 2
        left.add_patch(plt.Circle(centre[middle], conf.radius * grid.extent, fill=False, color=colour, alpha=0.5))
    for k, v in enumerate(np.linspace(0, scanner.n_views - 1, 9).astype(int)[1:-1]):  # that instant's ray
        theta = scanner.angles[v]
        ray = centres[0][v][:, None] + np.array([-np.sin(theta), np.cos(theta)])[:, None] * np.array([[-0.2, 0.2]])
        left.plot(*ray, color="0.5", lw=0.8, ls=":", label=None if k else "the ray of the view taken at that instant")
        left.plot(*np.stack([centres[0][v], centres[1][v]], axis=1), "k.", ms=4)
    left.set(xlim=(-0.5, 0.5), ylim=(-0.5, 0.5), aspect="equal", xlabel="x (field of view)",
             ylabel="y (field of view)", title="two trajectories (discs: half a turn in)")
    left.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=9, frameon=False)
    extent = (scanner.bin_positions[0], scanner.bin_positions[-1], 360 * scanner.rotations, 0)
    shown = right.imshow(sinos[0], aspect="auto", extent=extent, cmap="gray")
    fig.colorbar(shown, ax=right, label="line integral (field of view)")
    right.set(xlabel="detector coordinate u (field of view)", ylabel="gantry angle θ (degrees)",
              title=f"one sinogram: max |difference| = {difference:.1e}\n(peak value {sinos[0].max():.2f})")
    fig.suptitle("Motion along the rays of the view taken at that instant is invisible: 100°/rot, one rotation")
    return fig, difference


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", type=float, nargs="+", default=[100, 125, 150, 200, 300])
    parser.add_argument("--rotations", type=float, nargs="+", default=[1, 3])
    parser.add_argument("--noise-i0", type=float, default=None, help="incident photons per ray (default: none)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows = []
    for rotations in args.rotations:
        for deg in args.speeds:
            rows.append(measure(deg, rotations, args.noise_i0))
            print(", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in rows[-1].items()),
                  flush=True)
    fig, difference = ambiguity_figure()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=110)
    plt.close(fig)
    header = ["°/rot", "rotations", "spread (px, truth-free)", "verdict", "error max (px)", "error RMS (px)",
              "ℓ (rot)", "Legendre LSQ error max (px)", "s"]
    table = markdown_table(header, [[r["deg_per_rotation"], r["rotations"], r["spread_px"],
                                     "determined" if r["determined"] else "UNDETERMINED", r["error_max_px"],
                                     r["error_rms_px"], r["length_scale_rot"], r["legendre_error_max_px"],
                                     r["seconds"]] for r in rows])
    command = "python benchmarks/trajectory.py " + " ".join(sys.argv[1:] if argv is None else argv)
    noise = f"I0 = {args.noise_i0:g} photons per ray" if args.noise_i0 else "noiseless"
    centroid = max(r["centroid_error_px"] for r in rows)
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, args.out / "trajectory.csv")
    (args.out / "README.md").write_text(
        f"# Centroid trajectory and what the data cannot tell\n\n```\n{command.strip()}\n```\n\n"
        f"The circle experiment at 128 px, 720 views per rotation, {noise}. Errors are distances to the true "
        f"centre over all views; the spread is the verdict's value (`nct.moments.trajectory.determinacy`, "
        f"threshold 1 px). Centroid projections against the truth: at most {centroid:.4f} px. "
        f"docs/figures/ambiguity.png: max sinogram difference between the two trajectories {difference:.1e}.\n\n"
        f"{table}\n")
    print(table)


if __name__ == "__main__":
    main()
