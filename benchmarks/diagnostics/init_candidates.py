"""What the initialisation saw in a sinogram file: Algorithm 1's mixture classes and every candidate
the sinogram judge scored (``init.levels=sinogram``), best first, with the starts InitFit tries
(``init.starts``, K >= 2; each starts a candidate of the run's tournament: selection.csv,
metrics.json -> init -> start).

A diagnostic for a scene whose objects start wrong (benchmarks/results/generalisation/seed1:
scene011). The FBP frames and the judge are those of the run itself: ``nct.method.reconstruct.reconstruct``
is called and stopped where it hands them to the segmentation, so nothing here re-derives them.
Levels and a(k) are in the method's units: times the run's ``init.intensity_unit``
(metrics.json) for the data's.

    python benchmarks/diagnostics/init_candidates.py outputs/benchmarks/gen_seed1/scenes/scene011.npz --n-objects 2
    python benchmarks/diagnostics/init_candidates.py --override experiment=nodule --override seed=3
"""

from __future__ import annotations

import argparse
import copy
import tempfile
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_module
from hydra.errors import HydraException
from omegaconf.errors import OmegaConfBaseException

import nct.init.starts
from nct.cli.main import CONFIG_MODULE
from nct.errors import InputError, MethodError
from nct.init import segmentation as seg
from nct.run.config import validate
from nct.run.pipeline import acquire
from nct.run.reconstruct import reconstruct_scan
from nct.run.schema import NCTConf


class _Caught(Exception):
    """Carries a hooked call's arguments out of reconstruct()."""

    def __init__(self, args: tuple, kwargs: dict) -> None:
        super().__init__("hook reached")
        self.args_, self.kwargs = args, kwargs


def run_config(path: Path | None, n_objects: int | None, overrides: list[str]) -> NCTConf:
    """The run's validated config: the sinogram file ``path`` (None: the overrides' scene, e.g. an
    experiment) with K = ``n_objects`` (None: the config's), and ``overrides``."""
    scene = [] if path is None else ["data=file", f"data.path={path}"]
    k = [] if n_objects is None else [f"data.n_objects={n_objects}"]
    with initialize_config_module(config_module=CONFIG_MODULE, version_base="1.3"):
        try:
            cfg = compose(config_name="config", overrides=[*scene, *k, *overrides])
        except (HydraException, OmegaConfBaseException) as err:  # an unknown group, option or key
            raise InputError(f"overrides {overrides}: {str(err).splitlines()[0]}") from err
    return validate(cfg)


def run_until(conf: NCTConf, hook: str) -> tuple:
    """Run ``conf`` until it calls ``nct.init.starts.<hook>``: that call's positional arguments."""

    def catch(*args, **kwargs):
        raise _Caught(args, kwargs)

    scan = acquire(conf, np.random.default_rng(conf.seed))
    real = getattr(nct.init.starts, hook)
    setattr(nct.init.starts, hook, catch)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            reconstruct_scan(scan, conf, Path(tmp))
    except _Caught as caught:
        return caught.args_
    finally:
        setattr(nct.init.starts, hook, real)
    raise RuntimeError(f"the run ended without calling {hook}")


def segmentation_inputs(path: Path | None, n_objects: int | None, overrides: list[str]) -> tuple:
    """The run's FBP init frames [F, H, W] (method units), K, its generator, kappa, share, route and
    judge, and the number of starts InitFit tries (``init.starts``); arguments as `run_config`'s."""
    conf = run_config(path, n_objects, overrides)
    return *run_until(conf, "segmentations"), conf.init.starts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", type=Path, nargs="?", help="a sinogram file (.npz, the documented format; "
                        "none: the scene the overrides name, e.g. --override experiment=nodule)")
    parser.add_argument("--n-objects", type=int, help="data.n_objects (K; default: the config's)")
    parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE", help="an nct override")
    args = parser.parse_args()
    try:
        frames, k, rng, kappa, share, route, judge, starts = segmentation_inputs(args.path, args.n_objects,
                                                                                args.override)
    except (InputError, MethodError) as err:  # a bad file or value, or no object: one line, as nct says it
        parser.exit(2, f"init_candidates: error: {err}\n")
    classes = seg.mixture_classes(frames, k, copy.deepcopy(rng), kappa, share)
    print(f"mixture classes (method units): means {np.round(classes.means, 3)}, claimed levels "
          f"{np.round(classes.claimed, 3)}, spread {np.round(classes.spread, 3)}, pixels {classes.count}, "
          f"background class {classes.background}, foreground from {classes.lowest:.3f}")
    picked = seg.algorithm1_levels(classes, k)
    print("Algorithm 1's rule:", "fewer than K levels" if picked is None else np.round(picked, 3))
    ranked = seg.segmentations(frames, k, rng, kappa, share, route, judge)
    if judge is not None:
        print("the candidates the judge scored, best first:")
        for c in ranked:
            print(f"  route {c.route}, background {c.background:.3f}: judge misfit {c.misfit:.4f}, "
                  f"a(k) {np.round(c.intensities, 3)}, pixels per frame {np.round(c.masks.sum(axis=(0, 2, 3)) / len(c.masks), 1)}")
    tried = ranked[:starts] if k > 1 else ranked[:1]  # initialise.find_starts's rule
    for n, start in enumerate(tried):
        print(f"start {n}: route {start.route}, a(k) {np.round(start.intensities, 3)}, judge misfit {start.misfit}")
    if len(tried) > 1:
        print("each start begins a candidate of the run's tournament (selection.csv; metrics.json -> init -> start)")


if __name__ == "__main__":
    main()
