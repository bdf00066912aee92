"""Where claimed levels matter: for the generalisation benchmark's scenes, the judged choices of
levels with each mixture class's mean alone and with its claimed level beside it
(`nct.init.mixture.claimed_levels`), and whether the starts the run tries change.

A scene whose starts are the same is reconstructed as without the claimed levels; the others are
the ones to rerun with ``generalisation.py --only`` (benchmarks/results/background: session 43).
The segmentation inputs are the run's own (init_candidates.py).

    python benchmarks/diagnostics/level_choices.py --out outputs/level_choices [--scenes 100] [--only scene072]
"""

from __future__ import annotations

import argparse
import copy
import sys
from dataclasses import dataclass
from pathlib import Path
from unittest import mock

import numpy as np

from nct.init import mixture, segmentation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import generalisation as gen  # noqa: E402
from init_candidates import segmentation_inputs  # noqa: E402
from scene_files import write_scene  # noqa: E402


@dataclass(frozen=True)
class Choices:
    """One scene: the judged choices of levels with means only and with claimed levels, and whether
    the starts tried (their judge misfits and a(k)) are the same."""

    means_only: int
    with_claimed: int
    same_starts: bool


def compare(path: Path, n_objects: int, overrides: list[str]) -> Choices:
    """`Choices` for the sinogram file ``path`` with K = ``n_objects``."""
    frames, k, rng, kappa, share, route, judge, starts = segmentation_inputs(path, n_objects, overrides)
    tried = starts if k > 1 else 1

    def outcome() -> tuple[int, list]:
        classes = mixture.mixture_classes(frames, k, copy.deepcopy(rng), kappa, share)
        ranked = segmentation.segmentations(frames, k, copy.deepcopy(rng), kappa, share, route, judge)
        return len(mixture.class_choices(classes, k)), [(c.misfit, c.intensities.tolist()) for c in ranked[:tried]]

    n_claimed, kept = outcome()
    with mock.patch.object(mixture, "claimed_levels", lambda gmm, values, labels: gmm.means_[:, 0].copy()):
        n_means, before = outcome()
    return Choices(n_means, n_claimed, bool(np.allclose([m for m, _ in kept], [m for m, _ in before])
                                            and all(np.allclose(a, b) for (_, a), (_, b) in zip(kept, before))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=gen.FULL_SCENES, help="scenes drawn (default: the benchmark's)")
    parser.add_argument("--seed", type=int, default=0, help="the scene sampler's seed")
    parser.add_argument("--only", type=lambda text: text.split(","), metavar="SCENE,...", help="these scenes only")
    parser.add_argument("--out", type=Path, required=True, help="where the scene files are written")
    args = parser.parse_args()
    drawn = gen.draw_scenes(args.seed, args.scenes)
    unknown = sorted(set(args.only or ()) - {s.name for s in drawn})
    if unknown:
        parser.exit(2, f"level_choices: error: --only: not among the {len(drawn)} scenes drawn: {', '.join(unknown)}\n")
    scenes = [s for s in drawn if not args.only or s.name in args.only]
    changed = []
    for scene in scenes:
        path = write_scene(scene, args.out / "scenes" / f"{scene.name}.npz", gen.FULL_SIZE, gen.FULL_FRAMES, args.seed)
        c = compare(path, len(scene.objects), [f"seed={gen.NCT_SEED}"])
        print(f"{scene.name}: {c.means_only} choices with means only, {c.with_claimed} with claimed levels; "
              f"starts {'the same' if c.same_starts else 'CHANGED'}", flush=True)
        changed += [] if c.same_starts else [scene.name]
    print(f"starts changed on {len(changed)} of {len(scenes)} scenes: {','.join(changed) or 'none'}")


if __name__ == "__main__":
    main()
