"""The method's own units: the field of view's side is 1 and the objects' intensities are about 1.

Users bring data in any units (a field of view of 1, 25 cm or 400 mm; attenuation per mm, per
cm, or scaled by 10^3). Every step size, band width, regulariser and threshold of the method is
set in these units, so the data are mapped into them on the way in and the results mapped back
on the way out: the same scene gives the same reconstruction whatever its units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.errors import NoObjectError

PEAK_PERCENTILE = 99.9  # the intensity unit: this percentile of the FBP frames (robust to a few hot pixels)


@dataclass(frozen=True)
class Units:
    """The data's units in the method's: a length of ``length`` data units is one field-of-view
    side, an intensity of ``intensity`` data units is one method unit."""

    length: float
    intensity: float = 1.0

    def __post_init__(self) -> None:
        if not (self.length > 0 and np.isfinite(self.length)):
            raise ValueError(f"Units.length must be a finite number > 0, got {self.length}")
        if not (self.intensity > 0 and np.isfinite(self.intensity)):
            raise ValueError(f"Units.intensity must be a finite number > 0, got {self.intensity}")

    def grid(self, grid: ImageGrid) -> ImageGrid:
        """``grid`` in method units (side 1)."""
        return ImageGrid(grid.size, grid.extent / self.length)

    def sinogram(self, sino: Sinogram) -> Sinogram:
        """``sino`` in method units (line integrals are intensity x length), without its truth; I0
        kept, and the attenuation k rescaled so that k·p, the transmission's exponent, is unchanged."""
        scale = self.intensity * self.length
        values = np.asarray(sino.values, dtype=np.float64) / scale
        return Sinogram(values=values.astype(np.float32), angles=sino.angles, times=sino.times,
                        geometry=sino.geometry.scaled(1 / self.length), i0=sino.i0,
                        attenuation=sino.attenuation * scale)

    def with_intensity_of(self, frames: np.ndarray) -> "Units":
        """These units with the intensity unit set from FBP ``frames`` [F, H, W] already in these
        units: their PEAK_PERCENTILE-th percentile becomes 1."""
        peak = float(np.percentile(frames, PEAK_PERCENTILE))
        if not peak > 0 or not np.isfinite(peak):
            raise NoObjectError(f"the FBP of the sinogram has no positive intensity (its {PEAK_PERCENTILE}th "
                                f"percentile is {peak:.3g}): the sinogram holds no object")
        return Units(self.length, self.intensity * peak)


def field_of_view(grid: ImageGrid) -> Units:
    """Length units from the reconstruction grid: its side becomes 1."""
    return Units(length=grid.extent)
