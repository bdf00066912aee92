"""Time one SinogramFit step (forward, backward, Adam, Lightning's loop) per rung of the motion ladder and field family.

The cost of a step is what separates the rungs (issue 48: a rigid model should cost less than the free field it
undercuts); the render and projector part is shared (benchmarks/bench_projector.py). Each case runs the method's
own stage (`nct.fit.trainer.run_stage`) twice, ``--steps`` and ``--steps`` + ``--more``, and a step's cost is the
difference over ``--more``: Trainer start-up cancels out. Random views stand in for data: only the time is
measured. A moved template covers the whole image (its centre free), as a fit's does before its centre is held.
Run: python benchmarks/bench_fields.py [--size 128] [--views 20] [--threads 2] [--steps 20] [--more 100]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
import torch

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid
from nct.fields.build import build_field
from nct.fields.conf import RUNGS, ModelConf
from nct.fit.conf import CallbacksConf, LossConf, OptimConf, RenderConf, TrainerConf
from nct.fit.problem import Views
from nct.fit.stages import SinogramFit
from nct.fit.trainer import IndexDataModule, run_stage

FAMILIES = ("siren", "grid")
N_VIEWS = 720


@dataclass(frozen=True)
class StepCost:
    """One case's row: its family and rung, the field's parameter count and milliseconds per step."""

    family: str
    rung: str
    n_params: int
    ms_per_step: float


def stage_seconds(family: str, rung: str, size: int, views: int, steps: int, coarse: int) -> tuple[int, float, int]:
    """Parameters of the ``family`` field on ``rung``, the wall seconds of a SinogramFit of ``steps`` steps of
    ``views`` views on a size x size grid, its field drawn on a ``coarse`` lattice (optim.coarse_size), and the
    steps the stage ran."""
    gen = torch.Generator().manual_seed(0)
    data = Views(torch.rand(N_VIEWS, size, generator=gen), torch.linspace(0, 2 * np.pi, N_VIEWS),
                 torch.linspace(0, 1, N_VIEWS), ParallelGeometry(size, 2 / size))
    net = build_field(ModelConf(family=family), 1, torch.Generator().manual_seed(0), rung, 1.0)
    fit = SinogramFit(net, ImageGrid(size), OptimConf(), RenderConf(), LossConf(), data, steps, coarse)
    batches = IndexDataModule(np.arange(N_VIEWS), views, steps, 0)
    quiet = TrainerConf(callbacks=CallbacksConf(progress_bar=False, progress_every_s=0))
    start = time.perf_counter()
    record = run_stage(fit, batches, steps, f"{family}_{rung}", quiet, None, "none")
    return sum(p.numel() for p in net.parameters()), time.perf_counter() - start, record["steps"]


def step_cost(family: str, rung: str, size: int, views: int, steps: int, more: int, coarse: int) -> StepCost:
    """`StepCost` of one case: (seconds of steps + more) - (seconds of steps), per step of ``more``."""
    _, short, _ = stage_seconds(family, rung, size, views, steps, coarse)
    n_params, long, _ = stage_seconds(family, rung, size, views, steps + more, coarse)
    return StepCost(family, rung, n_params, 1000 * (long - short) / more)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--views", type=int, default=20)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--more", type=int, default=100)
    parser.add_argument("--coarse", type=int, default=OptimConf.coarse_size)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"SinogramFit step, {args.size}x{args.size}, {args.views} views, field on {args.coarse}^2, "
          f"{args.threads} thread(s), torch {torch.__version__}")
    for family in FAMILIES:
        for rung in RUNGS:
            cost = step_cost(family, rung, args.size, args.views, args.steps, args.more, args.coarse)
            print(f"{cost.family:6s} {cost.rung:7s} {cost.n_params:8d} params {cost.ms_per_step:7.1f} ms/step",
                  flush=True)


if __name__ == "__main__":
    main()
