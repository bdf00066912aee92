"""The ``nct-export`` command: re-render a finished run's fitted field at any times and resolution.

``nct-export RUN_DIR --frames N --size S`` writes ``RUN_DIR/export_<N>x<S>.npz`` with intensity
``frames`` [N, S, S], ``sdf`` [N, K, S, S] (float32, the data's units), ``times`` [N] (s) and
``extent``; ``--times`` picks the times instead, ``--gif`` and ``--tiff`` add a movie and a stack
beside it. It never overwrites a file. Errors are one line ``nct-export: error: ...``, exit code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

import numpy as np

from nct.errors import InputError

PROG = "nct-export"


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line (no usage block), like every other error."""

    def error(self, message: str) -> NoReturn:
        fail(message)


def fail(message: str) -> NoReturn:
    """End the command with ``nct-export: error: message`` on stderr and exit code 2."""
    print(f"{PROG}: error: {message}", file=sys.stderr)
    sys.exit(2)


def parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Render a finished NeuralCT run's fitted field at any times and "
                "resolution over the run's field of view: intensity and SDF frames in an .npz.")
    p.add_argument("run_dir", type=Path, metavar="RUN_DIR", help="the run's output folder")
    when = p.add_mutually_exclusive_group(required=True)
    when.add_argument("--frames", type=int, metavar="N", help="N times evenly spread over the acquisition")
    when.add_argument("--times", type=float, nargs="+", metavar="T",
                      help="times in seconds, as the run's reconstruction.npz 'times' (inside the acquisition)")
    p.add_argument("--size", type=int, metavar="S", help="pixels a side (default: the run's own grid)")
    p.add_argument("--out", type=Path, metavar="FILE", help="the .npz to write (default: RUN_DIR/export_<N>x<S>.npz)")
    p.add_argument("--gif", action="store_true", help="also write a movie, FILE with .gif")
    p.add_argument("--tiff", action="store_true", help="also write a float32 TIFF stack, FILE with .tiff")
    return p


def targets(out: Path, gif: bool, tiff: bool) -> list[Path]:
    """The files an export writes: the .npz, then the optional GIF and TIFF beside it."""
    return [out] + [out.with_suffix(".gif")] * gif + [out.with_suffix(".tiff")] * tiff


def export(args: argparse.Namespace) -> list[Path]:
    """Check the arguments against the run, render and write; return the files written."""
    from nct.method.reload import check_times, even_times, load_run, render
    from nct.run import export as files

    if args.frames is not None and args.frames < 1:
        raise InputError(f"--frames must be >= 1, got {args.frames}")
    if args.size is not None and args.size < 2:
        raise InputError(f"--size must be >= 2, got {args.size}")
    run = load_run(args.run_dir)
    fitted = run.fitted
    if args.times is not None:
        times = np.asarray(args.times, dtype=np.float64)
        check_times(fitted.span, times, "--times")
    else:
        times = even_times(fitted.span, args.frames)
    size = args.size or fitted.grid.size
    out = args.out or args.run_dir / f"export_{len(times)}x{size}.npz"
    if out.suffix != ".npz":
        raise InputError(f"--out must name an .npz file, got {out}")
    written = targets(out, args.gif, args.tiff)
    existing = [p for p in written if p.exists()]
    if existing:
        raise InputError(f"{existing[0]} exists and is never overwritten: choose another --out")
    frames, sdf = render(fitted, times, size)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, frames=frames, sdf=sdf, times=times, extent=np.float64(fitted.grid.extent))
    if args.gif:
        files.save_movie(out.with_suffix(".gif"), {"nct": frames}, times, run.fps, fitted.grid.extent)
    if args.tiff:
        files.save_tiffs(out.parent, {out.stem: frames}, times, fitted.grid.extent)
    return written


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point (``nct-export``); ``argv`` defaults to the command line."""
    args = parser().parse_args(argv)
    try:
        written = export(args)
    except InputError as err:
        fail(str(err))
    print("\n".join(str(p) for p in written))


if __name__ == "__main__":
    main()
