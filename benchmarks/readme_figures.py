"""The README's figures: run the default reconstruction and the thorax, and copy their pictures to docs/figures/.

Every picture in README.md comes from this command, so the README shows what `nct` writes today:
the default run's ``strip.png`` and ``metrics.png`` as it wrote them and one frame of its
``movie.gif`` (the middle one: truth | FBP | NCT at one instant) as ``movie_frame.png``; the middle
frame of ``nct experiment=thorax``'s movie (the whole image over a static background) as ``thorax_frame.png``.

Run: python benchmarks/readme_figures.py [--run-dir outputs/readme_figures] [--threads 1]
     python benchmarks/readme_figures.py --from-run outputs/runs/<run> [--thorax-run outputs/runs/<run>]
       # copy from finished runs
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
COPIED = ("strip.png", "metrics.png")  # written by every run with a truth, copied as they are
MAX_BYTES = 300_000  # a README picture stays small


def run_nct(run_dir: Path, threads: int, *overrides: str) -> None:
    """`nct` with ``overrides`` (none: the default, a circle at 100 deg/rotation) into ``run_dir``,
    replacing it; no TensorBoard, so nothing but the figures' run is timed and written."""
    shutil.rmtree(run_dir, ignore_errors=True)
    command = [sys.executable, "-m", "nct.cli.main", *overrides, f"threads={threads}", "logger=none",
               f"hydra.run.dir={run_dir}"]
    print("running:", " ".join(command[2:]), flush=True)
    subprocess.run(command, cwd=ROOT, check=True)


def movie_frame(movie: Path) -> np.ndarray:
    """The middle frame of the run's movie [H, W, 3] uint8 (a grey movie's too: its GIF holds grey levels)."""
    frames = iio.imread(movie, index=None, mode="RGB")
    return frames[len(frames) // 2]


def finished(run_dir: Path) -> Path:
    """``run_dir``, or exit naming how it ended when it did not finish."""
    status = json.loads((run_dir / "status.json").read_text())
    if status["status"] != "ok":
        raise SystemExit(f"readme_figures: error: {run_dir} ended {status['status']}: {status.get('error')}")
    return run_dir


def copy_figures(run_dir: Path, thorax_dir: Path, figures: Path) -> list[Path]:
    """Copy the runs' pictures into ``figures``; return the written paths. Refuses an unfinished run."""
    run_dir, thorax_dir = finished(run_dir), finished(thorax_dir)
    figures.mkdir(parents=True, exist_ok=True)
    written = []
    for name in COPIED:
        written.append(Path(shutil.copyfile(run_dir / name, figures / name)))
    for source, name in ((run_dir, "movie_frame.png"), (thorax_dir, "thorax_frame.png")):
        iio.imwrite(figures / name, movie_frame(source / "movie.gif"))
        written.append(figures / name)
    for path in written:
        if path.stat().st_size > MAX_BYTES:
            raise SystemExit(f"readme_figures: error: {path} is {path.stat().st_size} bytes (> {MAX_BYTES})")
    return written


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run-dir", type=Path, default=ROOT / "outputs" / "readme_figures",
                        help="where the default run writes (replaced if it exists)")
    parser.add_argument("--from-run", type=Path, help="copy from this finished default run instead of running it")
    parser.add_argument("--thorax-run", type=Path, help="copy from this finished thorax run instead of running it")
    parser.add_argument("--threads", type=int, default=1, help="torch threads of the run")
    parser.add_argument("--figures", type=Path, default=FIGURES, help="where the pictures go")
    args = parser.parse_args(argv)
    run_dir, thorax_dir = args.from_run, args.thorax_run
    if run_dir is None:
        run_dir = args.run_dir.resolve()
        run_nct(run_dir, args.threads)
    if thorax_dir is None:
        thorax_dir = args.run_dir.resolve().with_name(args.run_dir.name + "_thorax")
        run_nct(thorax_dir, args.threads, "experiment=thorax")
    for path in copy_figures(run_dir, thorax_dir, args.figures):
        print(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: {path.stat().st_size // 1000} KB")


if __name__ == "__main__":
    main()
