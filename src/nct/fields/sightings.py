"""Where a fit's objects were seen before it starts (centres, axes, reach): what a moved template or a
carried free field starts its motion from."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from nct.fields.lattice import pixel_centres
from nct.moments.orientation import ELONGATED

REACH_MARGIN = 1.5  # a template's half-width: this times its object's reach in the start's masks, plus
REACH_PAD = 0.1  # this (image units, 6 px at 128): room for a boundary the FBP masks cut short or an affine growth

@dataclass(frozen=True)
class Sightings:
    """Where K objects were seen at F ``times`` [F] (rotations), where a moved template starts
    (``start_motion``): centres [F, K, 2] (the image spans [-1, 1], x right, y up), angles
    [F, K] (rad, counter-clockwise) and ``reach`` [K], the farthest any object's pixel lay from its
    centre (image units: what its template must cover). ``held``: the centres are the mass centroid's
    path read off the views (initialise.sightings), which the fit keeps: the views' first moments
    tell all the data can of a rigid object's centre, and a fitted centre drifts along the rays
    where no view sees it (the circle at 150 deg/rotation: 8 px). ``turned``: the object whose angles are
    its axis read off the views (orientation.py: a lone one's, or one part's among still ones), which
    the free field turns with (None: none)."""

    times: Tensor
    centres: Tensor
    angles: Tensor
    reach: Tensor
    held: bool = False
    turned: int | None = None

    def cover(self) -> Tensor:
        """The half-width [K] a shape held in its object's frame covers: its reach with room
        (``REACH_MARGIN``, ``REACH_PAD``)."""
        return REACH_MARGIN * self.reach + REACH_PAD


def mask_sightings(masks: np.ndarray, times: Tensor) -> Sightings:
    """Objects seen in masks [F, K, H, W] bool over the image at ``times`` [F] (rotations): each
    mask's centroid, its principal axis where the masks are elongated (second moments
    differing by ``ELONGATED`` or more, else angle 0), and its reach."""
    u = pixel_centres(masks.shape[-1]).numpy().astype(np.float64)
    x, y = np.meshgrid(u, -u)
    weight = masks.astype(np.float64)
    area = weight.sum(axis=(2, 3)).clip(min=1)
    cx, cy = (weight * x).sum(axis=(2, 3)) / area, (weight * y).sum(axis=(2, 3)) / area  # [F, K]
    dx, dy = x - cx[..., None, None], y - cy[..., None, None]
    mxx, myy, mxy = ((weight * m).sum(axis=(2, 3)) / area for m in (dx * dx, dy * dy, dx * dy))
    spread = np.hypot(mxx - myy, 2 * mxy) / (mxx + myy).clip(min=1e-12)
    axis = np.unwrap(np.arctan2(2 * mxy, mxx - myy), axis=0) / 2  # the axis has period pi
    angles = np.where(np.median(spread, axis=0) >= ELONGATED, axis, 0.0)
    centres = torch.from_numpy(np.stack([cx, cy], axis=-1)).float()
    far = np.where(masks, np.hypot(dx, dy), 0.0).max(axis=(0, 2, 3))  # [K]; an empty object reaches 0
    return Sightings(times, centres, torch.from_numpy(angles).float(), torch.from_numpy(far).float())
