"""The stages' loss terms: the balanced L1 of InitFit weighs an object's inside as much as its outside; a still
field's step draws one frame."""

from __future__ import annotations

import math

import pytest
import torch

from nct.acquisition.geometry import ParallelGeometry
from nct.acquisition.scanner import ImageGrid
from nct.fields.build import build_field
from nct.fit.conf import LossConf, RenderConf
from nct.fit.problem import Views
from nct.fit.stages import SinogramFit, balanced_l1, weighted
from tests.conftest import MODEL, OPTIM


def test_balanced_l1_weighs_inside_and_outside_equally():
    """One inside pixel counts as much as the 15 outside: a field negative everywhere is no fit."""
    targets = -torch.ones(1, 1, 4, 4)
    targets[0, 0, 1, 1] = 1.0
    everywhere_outside = -torch.ones(1, 1, 4, 4)
    assert float(balanced_l1(everywhere_outside, targets)) == pytest.approx(0.5 * (2.0 + 0.0))
    assert float((everywhere_outside - targets).abs().mean()) == pytest.approx(2 / 16)  # what plain L1 gave


@pytest.mark.parametrize("rung", ["static", "free"])
def test_a_still_field_is_drawn_once_for_every_view(rung):
    """A static field's step draws one frame and sees it at every view's angle: the same views, to rounding, as
    drawing it once per view; a moving field draws a frame per view."""
    grid, n_views = ImageGrid(24), 6
    field = build_field(MODEL, 2, torch.Generator().manual_seed(0), rung)
    times = torch.linspace(0, 1, n_views)
    views = Views(torch.rand(n_views, 24), times * 2 * math.pi, times, ParallelGeometry(24, 1 / 24))
    stage = SinogramFit(field, grid, OPTIM, RenderConf(), LossConf(), views, steps=10)
    drawn, every = stage.drawn_sdf(times), stage.grid_sdf(times)
    assert drawn.shape[0] == (1 if rung == "static" else n_views) and every.shape[0] == n_views
    band, which = 2 * grid.pixel_size, torch.arange(n_views)
    torch.testing.assert_close(stage.render(drawn, which, band), stage.render(every, which, band))


def test_a_term_of_weight_zero_stays_out_of_the_graph():
    """A weight-0 regulariser is not computed on a step that does not log it, and without gradient on one that does;
    the others add weight x term to the loss in order."""
    x = torch.tensor(2.0, requires_grad=True)

    def never() -> torch.Tensor:
        raise AssertionError("a weight-0 term computed on a step that logs nothing")

    terms, loss = weighted(x * 3, {"eikonal": (0.5, lambda: x * x), "tv_time": (0.0, never)}, logged=False)
    assert set(terms) == {"sinogram", "eikonal"} and float(loss) == 6.0 + 0.5 * 4.0
    terms, _ = weighted(x * 3, {"tv_space": (0.0, lambda: x * x)}, logged=True)
    assert float(terms["tv_space"]) == 4.0 and terms["tv_space"].grad_fn is None


def test_adam_over_each_group_at_once_steps_as_the_loop_over_its_tensors():
    """The stages' Adam steps every tensor of a group at once (foreach) and takes the steps of CPU's default loop
    over each tensor, to the bit, over the warmup and a decay of the schedule: the fits are the loop's, cheaper."""
    torch.manual_seed(0)
    field = build_field(MODEL, 2, torch.Generator().manual_seed(0), "free")
    views = Views(torch.rand(6, 24), torch.linspace(0, 6, 6), torch.linspace(0, 1, 6), ParallelGeometry(24, 1 / 24))
    stage = SinogramFit(field, ImageGrid(24), OPTIM, RenderConf(), LossConf(), views, steps=10)
    params = [p for group in stage.param_groups() for p in group["params"]]
    start = [p.detach().clone() for p in params]
    grads = [[torch.randn_like(p) for p in params] for _ in range(OPTIM.lr_decay_every + 5)]

    def stepped(optimizer, scheduler) -> list[torch.Tensor]:
        with torch.no_grad():
            for p, s in zip(params, start):
                p.copy_(s)
        for step in grads:
            for p, g in zip(params, step):
                p.grad = g.clone()
            optimizer.step()
            scheduler.step()
        return [p.detach().clone() for p in params]

    ours = stage.configure_optimizers()
    optimizer, schedule = ours["optimizer"], ours["lr_scheduler"]["scheduler"].lr_lambdas[0]
    assert optimizer.defaults["foreach"]
    ends = stepped(optimizer, ours["lr_scheduler"]["scheduler"])
    loop = torch.optim.Adam(stage.param_groups(), lr=OPTIM.lr, foreach=False)
    looped = stepped(loop, torch.optim.lr_scheduler.LambdaLR(loop, schedule))
    assert all(torch.equal(a, b) for a, b in zip(ends, looped)) and not torch.equal(ends[0], start[0])
