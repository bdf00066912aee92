"""Can one turning part's axis be read off the views' second moments among still ones (issue 27)?

A diagnosis, not a reconstruction; it reads the truth to score the answer. For a generalisation
scene whose moving part turns about a still centre beside still objects (scene067: an ellipse
turning 172°/rotation beside two still ones), the whole mass's centroid stays put, so each view's
central second moment is a still quadratic form plus the turning part's: A + B0 cos 2θ + C0 sin 2θ
+ B cos 2(θ − φ(t)). A grid of steady turns φ = φ0 + ωt (each a linear least-squares fit of the
five) finds ω; the lone-object model (moments/orientation.py, three terms) is fitted too. Prints
both turns and their misfits against the true one, and the method's verdict (orientation.turning_part:
held or not, the turn it reads). ``--scenes all``: every scene of two or more objects, one line each.

    python benchmarks/diagnostics/turning_part.py [--scenes scene067 ... | all] [--size 128]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the independent scenes
from scene_files import add_noise, detector, line_integrals  # noqa: E402
from scenes import Pose, draw_scene  # noqa: E402

from nct.acquisition.geometry import ParallelGeometry  # noqa: E402
from nct.acquisition.sinogram import Sinogram  # noqa: E402
from nct.moments.orientation import (
    orientation_path,
    second_moments,
    steady_turn,
    turning_part,
)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["scene067"], help="scenes of the generalisation benchmark (seed 0)")
    parser.add_argument("--size", type=int, default=128, help="detector bins per field of view")
    args = parser.parse_args(argv)
    if args.scenes == ["all"]:
        for index in range(100):
            scene = draw_scene(0, index)
            if len(scene.objects) > 1:
                verdict(scene, args.size)
        return
    for name in args.scenes:
        print(name)
        report(draw_scene(0, int(name.removeprefix("scene"))), args.size)


def views(scene, size: int) -> Sinogram:
    """The scene's analytic parallel views at ``size`` bins, with the benchmark's own noise where it has any."""
    acq = scene.acquisition
    n_bins, spacing = detector(scene, size)
    values = line_integrals(scene, size)
    if scene.noise_i0 is not None:  # the benchmark's own noise (scene_files.add_noise), in unit-FOV lengths
        values = add_noise(values * scene.extent, scene.noise_i0, scene.extent,
                           np.random.default_rng([0, scene.index, 1])) / scene.extent
    return Sinogram(values.astype(np.float32), acq.angles(), acq.times(), ParallelGeometry(n_bins, spacing))


def true_turns(scene) -> list[float]:
    """Each object's turn over the scan, degrees per rotation."""
    acq = scene.acquisition
    return [float(np.degrees(np.ptp(Pose.of(scene, i, acq.times()).angle)) / acq.rotations)
            for i in range(len(scene.objects))]


def verdict(scene, size: int) -> None:
    """One line: the objects' motions and true turns, and what turning_part reads and whether it is held."""
    sino = views(scene, size)
    truth = " ".join(f"{obj.motion.kind} {turn:+.0f}" for obj, turn in zip(scene.objects, true_turns(scene)))
    axis = turning_part(sino)
    if axis is None or not axis.held:
        print(f"scene{scene.index:03d} not held | {truth}")
        return
    phi = axis.at(np.asarray(sino.times, dtype=np.float64))
    print(f"scene{scene.index:03d} HELD, turn {np.degrees(phi[-1] - phi[0]) / scene.acquisition.rotations:+.1f} "
          f"deg/rotation, misfit {axis.residual / axis.anisotropy:.3f} B | {truth}")


def report(scene, size: int) -> None:
    """Print the true turns, the three- and five-term fits and orientation_path's verdict for ``scene``."""
    acq = scene.acquisition
    sino = views(scene, size)
    moments = second_moments(sino)
    theta = np.asarray(sino.angles, dtype=np.float64)
    tau = (acq.times() - acq.times()[0]) / acq.rotation_time
    for i, obj in enumerate(scene.objects):
        pose = Pose.of(scene, i, acq.times())
        turn = np.degrees(pose.angle[-1] - pose.angle[0]) / acq.rotations
        print(f"  object {i}: {obj.motion.kind}, true turn {turn:+.1f} deg/rotation, axis at the first view "
              f"{math.degrees(pose.angle[0]) % 180:.1f} deg")
    for still in (False, True):
        omega, coef, misfit = steady_turn(theta, tau, moments, still)
        phi0 = 0.5 * math.atan2(coef[2], coef[1])
        print(f"  {'five terms (a still rest)' if still else 'three terms (a lone shape)'}: turn "
              f"{math.degrees(omega):+.1f} deg/rotation, axis at the first view {math.degrees(phi0) % 180:.1f} deg, "
              f"RMS misfit {misfit:.3g} (moments' spread {moments.std():.3g})")
    lone = orientation_path(sino)
    print(f"  orientation_path (a lone shape): held {lone.held}, B/A {lone.anisotropy / lone.isotropic:.3f}, "
          f"misfit / B {lone.residual / max(lone.anisotropy, 1e-30):.3g}")
    print("  turning_part (the method's verdict): ", end="")
    verdict(scene, size)

if __name__ == "__main__":
    main()
