"""Glyphs morphed one into the next through their signed distance functions (`phantoms.LettersConf`),
rasterised finely and projected pixel-driven along the scanner geometry's rays (``shapes.py``'s
detector model)."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from nct.acquisition.scanner import ImageGrid, Scanner
from nct.scenes.shapes import Phantom, block_mean, check_supersample

PROJECT_REFINE = 4  # rasterised scenes are projected from a grid this many times finer
GLYPH_FONT = {"family": "DejaVu Sans", "weight": "bold"}


@lru_cache(maxsize=64)
def glyph_polygons(char: str) -> tuple[np.ndarray, ...]:
    """Outline polygons of ``char`` at font size 1 (cap height ~0.73), each [P, 2]."""
    from matplotlib.font_manager import (
        FontProperties,  # lazy, as in _glyph_sdfs: only letters need matplotlib
    )
    from matplotlib.textpath import TextPath

    outline = TextPath((0, 0), char, size=1, prop=FontProperties(**GLYPH_FONT))
    return tuple(np.asarray(p) for p in outline.to_polygons())


def _glyph_layout(char: str, glyph_size: float) -> tuple[float, np.ndarray]:
    """Scale and offset placing ``char`` with cap height ``glyph_size``, bounding box centred."""
    scale = glyph_size / glyph_polygons("H")[0][:, 1].max()
    pts = np.concatenate(glyph_polygons(char))
    return scale, -(pts.min(axis=0) + pts.max(axis=0)) / 2


def glyph_reach(char: str, glyph_size: float) -> float:
    """Largest distance from the FOV centre of the placed glyph's outline (FOV fractions)."""
    scale, offset = _glyph_layout(char, glyph_size)
    return float(max(np.hypot(*((p + offset) * scale).T).max() for p in glyph_polygons(char)))


@lru_cache(maxsize=4)
def _glyph_sdfs(chars: str, glyph_size: float, size: int) -> np.ndarray:
    """Signed distance (fine pixels, positive inside) of each glyph on a size² grid of unit
    extent, rows y-down: [len(chars), size, size] float32. Holes by the even-odd rule."""
    from matplotlib.path import (
        Path,  # lazy: the config (this module's phantoms) is read before any scene is drawn
    )
    from scipy.ndimage import distance_transform_edt

    x, y = ImageGrid(size, 1.0).xy()
    pts = np.column_stack([x.ravel(), y.ravel()])
    out = np.empty((len(chars), size, size), dtype=np.float32)
    for i, char in enumerate(chars):
        scale, offset = _glyph_layout(char, glyph_size)
        inside = np.zeros(len(pts), dtype=bool)
        for poly in glyph_polygons(char):
            inside ^= Path((poly + offset) * scale).contains_points(pts)
        inside = inside.reshape(size, size)
        out[i] = distance_transform_edt(inside) - distance_transform_edt(~inside)
    return out


class LetterPhantom(Phantom):
    """The glyphs of ``sequence`` (cap height ``glyph_size`` of the FOV) morphing one into the next over
    ``rotations`` gantry rotations, ``hold_fraction`` of that time held still (`phantoms.LettersConf`):
    at each time the blend (1−w)·sdf_k + w·sdf_{k+1} > 0, with w a half-cosine ease across each
    morph, so shapes change smoothly and topology may change."""

    def __init__(self, sequence: str, glyph_size: float, hold_fraction: float, rotations: float, intensity: float,
                 rotation_time: float) -> None:
        self.sequence, self.glyph_size, self.hold_fraction, self.rotations = sequence, glyph_size, hold_fraction, rotations
        self.intensity = intensity
        self.intensities = (float(intensity),)
        self.rotation_time = rotation_time

    def _durations(self) -> tuple[float, float]:
        """Hold and morph durations in rotations."""
        n, span = len(self.sequence), self.rotations
        hold = self.hold_fraction * span / n
        return hold, (span - n * hold) / (n - 1) if n > 1 else 0.0

    def hold_times(self) -> np.ndarray:
        """Middle of each letter's stationary hold, in seconds: [len(sequence)]."""
        hold, morph = self._durations()
        return (np.arange(len(self.sequence)) * (hold + morph) + hold / 2) * self.rotation_time

    def state(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Letter index k [T] int and eased blend weight w [T] toward letter k+1 at ``times`` (s) [T];
        the first letter holds before 0 and the last after the scene's span."""
        hold, morph = self._durations()
        last = len(self.sequence) - 1
        tau = np.clip(np.asarray(times, dtype=np.float64) / self.rotation_time, 0.0, self.rotations)
        if last == 0:
            return np.zeros(tau.shape, dtype=int), np.zeros(tau.shape)
        k = np.minimum(np.floor(tau / (hold + morph)).astype(int), last)
        w = np.clip((tau - k * (hold + morph) - hold) / morph, 0.0, 1.0)
        return k, (1 - np.cos(math.pi * w)) / 2

    def _sdfs(self, size: int) -> np.ndarray:
        """SDF of each letter of the sequence on a size² grid: [len(sequence), size, size]."""
        chars = "".join(dict.fromkeys(self.sequence))
        sdfs = _glyph_sdfs(chars, float(self.glyph_size), size)
        return sdfs[[chars.index(c) for c in self.sequence]]

    def _fine_mask(self, k: int, w: float, sdfs: np.ndarray) -> np.ndarray:
        """Occupancy of letter k blended toward k+1 by w (w = 0 also serves the last letter)."""
        if w == 0.0:
            return sdfs[k] > 0
        return (1 - w) * sdfs[k] + w * sdfs[k + 1] > 0

    def image(self, t: float, grid: ImageGrid, supersample: int = 4) -> np.ndarray:
        check_supersample(supersample)
        (k,), (w,) = self.state(np.array([t]))
        fine = self._fine_mask(int(k), float(w), self._sdfs(grid.size * supersample))
        return block_mean(fine * np.float32(self.intensity), supersample)

    def project(self, scanner: Scanner, grid: ImageGrid) -> np.ndarray:
        """Pixel-driven: each occupied fine pixel's mass goes to sub-bins (``PROJECT_REFINE`` per
        bin) by linear interpolation of the detector coordinate it projects to, over the width of
        detector that sees it (``Geometry.project_points``); sub-bins are averaged per bin."""
        geometry = scanner.geometry
        fine = grid.refined(PROJECT_REFINE)
        sdfs = self._sdfs(fine.size)
        x, y = (c.ravel() for c in fine.xy())
        n_sub = scanner.n_bins * PROJECT_REFINE
        sub_width = scanner.bin_spacing / PROJECT_REFINE
        first_centre = geometry.bin_edges[0] + sub_width / 2
        mass = self.intensity * fine.pixel_size**2 / sub_width
        sino = np.zeros((scanner.n_views, n_sub))
        ks, ws = self.state(scanner.times)
        for view, (theta, k, w) in enumerate(zip(scanner.angles, ks, ws)):
            on = self._fine_mask(int(k), float(w), sdfs).ravel()
            u, scale = (a[0] for a in geometry.project_points(x[on], y[on], np.array([theta])))
            u = (u - first_centre) / sub_width
            lo = np.floor(u).astype(np.int64)
            frac = u - lo
            idx = np.concatenate([lo, lo + 1])
            wts = np.concatenate([1 - frac, frac]) * np.tile(scale, 2)
            keep = (idx >= 0) & (idx < n_sub)
            sino[view] = np.bincount(idx[keep], wts[keep], minlength=n_sub)
        sino *= mass
        return sino.reshape(scanner.n_views, scanner.n_bins, PROJECT_REFINE).mean(axis=2).astype(np.float32)
