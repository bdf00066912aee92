"""Time one SinogramFit step (forward + backward + Adam) per field family, static and moving.

The cost of a step is what separates the families; the render and projector part is shared
(benchmarks/bench_projector.py). Random views stand in for data: only the time is measured.
Run: python benchmarks/bench_fields.py [--size 128] [--views 20] [--threads 1]
"""

from __future__ import annotations

import argparse
import time

import torch

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid
from nct.fields.build import build_field
from nct.fields.conf import ModelConf
from nct.fit.conf import LossConf, OptimConf, RenderConf
from nct.fit.problem import Views
from nct.fit.stages import SinogramFit

CASES = (("siren", {}), ("siren", {"n_terms": 0}), ("grid", {}), ("grid", {"n_terms": 0}), ("siren", {
    "width": 256, "temporal_width": 128, "n_terms": 128, "f_max": 3.0}))


def step_ms(model: ModelConf, size: int, views: int, steps: int = 20, warmup: int = 5) -> tuple[int, float]:
    """Parameters of the field and median milliseconds per SinogramFit step on a size x size grid."""
    n_views = 720
    data = Views(torch.rand(n_views, size), torch.linspace(0, 6.28, n_views), torch.linspace(0, 1, n_views),
                 ParallelGeometry(size, 1 / size))
    net = build_field(model, 1, torch.Generator().manual_seed(0))
    fit = SinogramFit(net, ImageGrid(size, 1.0), OptimConf(), RenderConf(), LossConf(), data, torch.tensor([1.0]), steps)
    fit.log_dict = lambda *args, **kwargs: None  # outside a Trainer: nothing to log to
    opt = torch.optim.Adam(fit.parameters(), 1e-3)
    batches = torch.Generator().manual_seed(1)
    times = []
    for i in range(warmup + steps):
        start = time.perf_counter()
        loss = fit.training_step(torch.randint(0, n_views, (views,), generator=batches), i)
        opt.zero_grad()
        loss.backward()
        opt.step()
        times.append(time.perf_counter() - start)
    return sum(p.numel() for p in net.parameters()), 1000 * float(torch.tensor(times[warmup:]).median())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--views", type=int, default=20)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"SinogramFit step, {args.size}x{args.size}, {args.views} views, {args.threads} thread(s)")
    for family, changes in CASES:
        model = ModelConf(family=family, **changes)
        n_params, ms = step_ms(model, args.size, args.views)
        print(f"{family:6s} {str(changes) or '{}':70s} {n_params:8d} params {ms:7.1f} ms/step")


if __name__ == "__main__":
    main()
