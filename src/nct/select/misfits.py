"""How well a fit explains the views it never saw (``heldout``), against two references from the data alone.

The fit's relative L1 misfit on the held-out views is set against FBP's, from the same fitted views at each
held-out view's time, projected at its angle (a model-free reconstruction: its misfit holds its motion blur),
and the noise's, the misfit that a perfect fit would still have. The race reads them to race one more scene
model (select/race.py), the run to warn (run/suspect.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.fit.conf import HeldoutConf
from nct.fit.problem import split_views, subset
from nct.physics.conf import FBPConf
from nct.physics.data_term import MAD_TO_STD
from nct.physics.fbp import fbp_frames
from nct.physics.projector import project

MAX_FRAME_VALUES = 2**26  # FBP frames held at once: 256 MiB of float32


@dataclass(frozen=True)
class HeldoutMisfits:
    """Relative L1 misfits on the held-out views (mean |residual| over the mean |value| of all
    views): ``nct`` the fit's, ``fbp`` FBP's, ``noise`` the noise's alone (0 for noiseless data)."""

    nct: float
    fbp: float
    noise: float

    def above_fbp(self, ratio: float) -> bool:
        """Whether, beyond the noise, the fit misfits the held-out views more than ``ratio`` x FBP does: the
        race then races the next scene model (select/race.py, ``motion.fbp_ratio``), the run warns
        (run/suspect.py, ``suspect.fbp_ratio``)."""
        return self.nct - self.noise > ratio * (self.fbp - self.noise)


def noise_misfit(values: np.ndarray) -> float:
    """The relative L1 misfit that noise alone gives, from the data without a noise model: each
    view against its two neighbours' mean has the noise std × sqrt(1.5); per detector bin, the
    median over views (robust to the edges that move past), as a std (`MAD_TO_STD`), then
    E|noise| = sqrt(2/pi) std. values: [V, B] line integrals, views in acquisition order."""
    v = np.asarray(values, dtype=np.float64)
    if v.shape[0] < 3:
        return 0.0
    wiggle = np.abs(v[1:-1] - 0.5 * (v[:-2] + v[2:])) / math.sqrt(1.5)
    std = MAD_TO_STD * np.median(wiggle, axis=0)  # [B]
    return float(math.sqrt(2 / math.pi) * std.mean() / max(float(np.abs(v).mean()), 1e-30))


@torch.no_grad()
def fbp_misfit(sino: Sinogram, grid: ImageGrid, fit: np.ndarray, held: np.ndarray, fbp: FBPConf) -> float:
    """FBP's relative L1 misfit on the ``held`` views [h]: a frame from the ``fit`` views [f] at
    each held-out view's time, projected at its angle."""
    fitted = subset(sino, fit)
    chunk = max(1, MAX_FRAME_VALUES // grid.size**2)
    total = 0.0
    for part in np.array_split(held, math.ceil(len(held) / chunk)):
        frames = fbp_frames(fitted, grid, sino.times[part], fbp.window_deg, fbp.filter)
        views = project(torch.from_numpy(frames), torch.as_tensor(sino.angles[part], dtype=torch.float32),
                        sino.geometry, grid.extent)
        total += float(np.abs(views.double().numpy() - sino.values[part]).sum())
    return total / (len(held) * sino.values.shape[1]) / max(float(np.abs(sino.values).mean()), 1e-30)


def heldout_misfits(sino: Sinogram, grid: ImageGrid, nct: float, heldout: HeldoutConf,
                    fbp: FBPConf) -> HeldoutMisfits | None:
    """The misfits of a fit whose held-out misfit is ``nct``, on ``heldout``'s split of ``sino``;
    None when no view is held out (nothing to judge by)."""
    fit, held = split_views(sino.n_views, heldout.every, heldout.run)
    if not len(held) or not math.isfinite(nct):
        return None
    return HeldoutMisfits(nct, fbp_misfit(sino, grid, fit, held, fbp), noise_misfit(sino.values))
