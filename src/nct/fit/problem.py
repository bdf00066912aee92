"""The first step of a reconstruction: the data in the method's units, split into fitted and held-out views.

Every n-th view (``heldout.every``) is held out of everything, FBP included, and scores each fit
afterwards: the truth-free number every choice is made by (select/tournament.py). Time is measured in gantry
rotations from the first view, derived from the views' angles and times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import Tensor

from nct.acquisition.geometry import Geometry
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.fit.conf import HeldoutConf, LossConf
from nct.fit.units import Units, field_of_view
from nct.init.conf import InitConf
from nct.moments.compensation import compensated_frames
from nct.moments.orientation import orientation_path, turning_part
from nct.moments.trajectory import centroid_path, steady_mass
from nct.physics.data_term import view_noise
from nct.physics.fbp import fbp_frames


@dataclass(frozen=True)
class Clock:
    """Seconds -> gantry rotations since the first view (at ``t0`` s; ``turns_per_s`` rotations a
    second): [T] -> [T] float32. Two numbers, so a saved field keeps its clock (method/fitted.py)."""

    t0: float
    turns_per_s: float

    def __call__(self, t: np.ndarray) -> torch.Tensor:
        return torch.as_tensor((np.asarray(t, dtype=np.float64) - self.t0) * self.turns_per_s, dtype=torch.float32)


def rotations_since_start(sino: Sinogram) -> Clock:
    """Map seconds to gantry rotations since the first view, from the views' angles and times."""
    span_t = float(np.ptp(sino.times))
    turns_per_s = float(np.ptp(np.unwrap(sino.angles))) / (2 * math.pi) / span_t if span_t > 0 else 0.0
    if not turns_per_s > 0:
        raise ValueError("the sinogram's views must span a positive time and gantry angle")
    return Clock(float(sino.times[0]), turns_per_s)


def rotations_spanned(sino: Sinogram) -> float:
    """Gantry rotations from the first view to the last."""
    return float(rotations_since_start(sino)(sino.times).max())


def split_views(n_views: int, every: int, run: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the fitted and the held-out views: runs of ``run`` consecutive views, every
    ``every``-th run held out (the middle one of each ``every`` runs)."""
    if every < 2:
        return np.arange(n_views), np.zeros(0, dtype=int)
    held = (np.arange(n_views) // run) % every == every // 2
    return np.flatnonzero(~held), np.flatnonzero(held)


def subset(sino: Sinogram, views: np.ndarray) -> Sinogram:
    """The given views of ``sino``, without its truth."""
    return replace(sino, values=sino.values[views], angles=sino.angles[views], times=sino.times[views], truth=None)


def heldout_standard_error(losses: np.ndarray, blocks: int = 10) -> float:
    """Standard error of the mean of per-view held-out ``losses`` [v] (in time order), from the
    means of ``blocks`` contiguous blocks: neighbouring views see nearly the same object and
    angle, so their misfits are not independent. NaN with fewer than 2 views."""
    if len(losses) < 2:
        return float("nan")
    means = [part.mean() for part in np.array_split(losses, min(blocks, len(losses)))]
    return float(np.std(means, ddof=1) / math.sqrt(len(means)))


HeldoutHistory = list[tuple[int, float]]  # (step, held-out misfit) at each held-out check of a fit


@dataclass(frozen=True)
class Views:
    """Measured views as tensors: values [V, n_bins], angles [V] rad, times [V] in rotations; the rays' geometry;
    sigma [V, n_bins]: each value's noise std for the data term (None: the L1 term)."""

    values: Tensor
    angles: Tensor
    times: Tensor
    geometry: Geometry
    sigma: Tensor | None = None

    @property
    def scale(self) -> float:
        """Mean |value|: the sinogram loss is relative to it."""
        return float(self.values.abs().mean().clamp_min(1e-12))


@dataclass
class Problem:
    """What every fit of a run shares, in the method's units (fit/units.py): the ``grid``, the
    ``views`` (all of them; fits sample ``fit_views``, ``held_views`` score them), the FBP frames
    ``fbp`` [F, H, W] of the fitted views at ``init_times`` [F] (rotations), the ``units`` and the
    ``clock``; for a lone object, its mass centroid's ``centres`` [F, 2] at ``init_times`` read off
    the fitted views (image coordinates: [-1, 1], x right, y up; None otherwise) and, where it is
    elongated and rigid, its principal axis's ``orientations`` [F] (rad, counter-clockwise; None
    otherwise: orientation.py); among several objects, the axis of one rigid part turning about a
    still centre beside still ones, ``part_orientations`` [F] (None: none held; which object it is,
    the tournament chooses); the FBP frames' settings."""

    grid: ImageGrid
    loss: LossConf
    views: Views
    fbp: np.ndarray
    init_times: torch.Tensor
    fit_views: np.ndarray
    held_views: np.ndarray
    units: Units
    clock: Clock
    centres: np.ndarray | None = None
    orientations: np.ndarray | None = None
    part_orientations: np.ndarray | None = None
    fbp_window_deg: float = 180.0
    fbp_filter: str = "ramp"

    @property
    def span(self) -> float:
        """Gantry rotations from the first view to the last."""
        return float(self.views.times.max())

    def check_views(self, most: int = 64) -> np.ndarray:
        """The views that score a fit: the held-out ones, or up to ``most`` fitted ones when none is held out."""
        if len(self.held_views):
            return self.held_views
        return self.fit_views[np.unique(np.linspace(0, len(self.fit_views) - 1, most).round().astype(int))]

    def empty_misfit(self) -> float:
        """The misfit an empty image scores on ``check_views``: a fit no better than it explains nothing."""
        check = torch.from_numpy(self.check_views())
        return float(self.views.values[check].abs().sum(-1).mean()) / self.views.values.shape[1] / self.views.scale

    def fitted_sinogram(self) -> Sinogram:
        """The fitted views as a sinogram: method units, times in rotations."""
        v, fitted = self.views, torch.from_numpy(self.fit_views)
        return Sinogram(v.values[fitted].numpy(), v.angles[fitted].double().numpy(), v.times[fitted].double().numpy(),
                        v.geometry)

    def held_losses(self, checked: np.ndarray) -> np.ndarray:
        """The held-out views' misfits [h] among ``checked`` ones (``check_views``): none when no view
        is held out (the check then ran on fitted views)."""
        return checked if len(self.held_views) else np.zeros(0)


def prepare(sino: Sinogram, grid: ImageGrid, loss: LossConf, init: InitConf, heldout: HeldoutConf,
            fbp_filter: str, fbp_window_deg: float, lone: bool = False, parts: bool = False) -> Problem:
    """The ``Problem`` of reconstructing ``sino`` on ``grid``: views split, FBP frames of the fitted
    views at ``init.frames_per_rotation``, data scaled to a field of view of side 1 and the FBP's peak.
    With one object ``lone`` in the views (no background) whose mass stays steady (a rigid mover;
    trajectory.steady_mass), its centroid's path is read off their first moments (parallel beam:
    trajectory.centroid_path) and the FBP frames undo its translation (moments/compensation.py); where it is
    elongated and rigid, its axis is read off their second moments too (orientation.py). With several
    objects and no background (``parts``), the axis of one part turning among still ones is read there
    (orientation.turning_part); the FBP frames stay plain."""
    clock = rotations_since_start(sino)
    fit_views, held_views = split_views(sino.n_views, heldout.every, heldout.run)
    n_init = max(2, round(init.frames_per_rotation * float(clock(sino.times[-1]))))
    init_times = sino.times[0] + (np.arange(n_init) + 0.5) * (np.ptp(sino.times) / n_init)
    lengths = field_of_view(grid)
    grid = lengths.grid(grid)
    fitted = subset(lengths.sinogram(sino), fit_views)
    centres = orientations = part = None
    path = centroid_path(fitted) if lone and steady_mass(fitted) else None
    if path is not None:
        axis = orientation_path(fitted)
        axis = axis if axis is not None and axis.held else None
        fbp = compensated_frames(fitted, path, grid, init_times, fbp_window_deg, fbp_filter, axis)
        centres = path.at(init_times) * 2 / grid.extent
        if axis is not None:
            orientations = axis.at(init_times)
    else:
        fbp = fbp_frames(fitted, grid, init_times, fbp_window_deg, fbp_filter)
        axis = turning_part(fitted) if parts else None
        if axis is not None and axis.held:
            part = axis.at(init_times)
    units = lengths.with_intensity_of(fbp)
    fbp, sino = fbp / units.intensity, units.sinogram(sino)  # lengths' intensity unit is 1
    views = Views(torch.from_numpy(np.asarray(sino.values, dtype=np.float32)),
                  torch.as_tensor(sino.angles, dtype=torch.float32), clock(sino.times), sino.geometry,
                  view_noise(sino, loss.data_term))
    return Problem(grid, loss, views, fbp, clock(init_times), fit_views, held_views, units, clock, centres,
                   orientations, part, fbp_window_deg, fbp_filter)
