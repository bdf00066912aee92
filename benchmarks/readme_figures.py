"""The README's figures: run the default reconstruction and copy the pictures it wrote to docs/figures/.

Every picture in README.md comes from this command, so the README shows what `nct` writes today:
``strip.png`` and ``metrics.png`` as the run wrote them, and one frame of ``movie.gif`` (the middle
one: truth | FBP | NCT at one instant) as ``movie_frame.png``.

Run: python benchmarks/readme_figures.py [--run-dir outputs/readme_figures] [--threads 1]
     python benchmarks/readme_figures.py --from-run outputs/runs/<run>   # copy from a finished run
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


def run_default(run_dir: Path, threads: int) -> None:
    """The default `nct` (circle at 100 deg/rotation) into ``run_dir``; no TensorBoard, so nothing but
    the figures' run is timed and written."""
    command = [sys.executable, "-m", "nct.cli.main", f"threads={threads}", "logger=none",
               f"hydra.run.dir={run_dir}"]
    print("running:", " ".join(command[2:]), flush=True)
    subprocess.run(command, cwd=ROOT, check=True)


def movie_frame(movie: Path) -> np.ndarray:
    """The middle frame of the run's movie [H, W, 3] uint8."""
    frames = iio.imread(movie, index=None)
    return frames[len(frames) // 2][..., :3]


def copy_figures(run_dir: Path, figures: Path) -> list[Path]:
    """Copy the run's pictures into ``figures``; return the written paths. Refuses an unfinished run."""
    status = json.loads((run_dir / "status.json").read_text())
    if status["status"] != "ok":
        raise SystemExit(f"readme_figures: error: {run_dir} ended {status['status']}: {status.get('error')}")
    figures.mkdir(parents=True, exist_ok=True)
    written = []
    for name in COPIED:
        written.append(Path(shutil.copyfile(run_dir / name, figures / name)))
    iio.imwrite(figures / "movie_frame.png", movie_frame(run_dir / "movie.gif"))
    written.append(figures / "movie_frame.png")
    for path in written:
        if path.stat().st_size > MAX_BYTES:
            raise SystemExit(f"readme_figures: error: {path} is {path.stat().st_size} bytes (> {MAX_BYTES})")
    return written


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run-dir", type=Path, default=ROOT / "outputs" / "readme_figures",
                        help="where the default run writes (replaced if it exists)")
    parser.add_argument("--from-run", type=Path, help="copy from this finished run instead of running")
    parser.add_argument("--threads", type=int, default=1, help="torch threads of the run")
    parser.add_argument("--figures", type=Path, default=FIGURES, help="where the pictures go")
    args = parser.parse_args(argv)
    run_dir = args.from_run
    if run_dir is None:
        run_dir = args.run_dir.resolve()
        shutil.rmtree(run_dir, ignore_errors=True)
        run_default(run_dir, args.threads)
    for path in copy_figures(run_dir, args.figures):
        print(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: {path.stat().st_size // 1000} KB")


if __name__ == "__main__":
    main()
