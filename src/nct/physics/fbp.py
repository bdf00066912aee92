"""Filtered backprojection in parallel beam with a centred detector (s = x cos θ + y sin θ, bin i at
(i − (n − 1)/2)·bin_spacing): `fbp` of one set of views, `fbp_frames` at any times from a window of
views about each (any geometry: rebinned onto such rays first, ``acquisition/rebin.py``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from nct.acquisition.rebin import to_parallel
from nct.acquisition.scanner import ImageGrid
from nct.acquisition.sinogram import Sinogram
from nct.physics.conf import FILTERS

# Backprojection works on chunks of views holding at most this many pixel samples (bounds memory).
_CHUNK_SAMPLES = 2**22


def filter_sinogram(values: Tensor, bin_spacing: float, filter: str = "ramp") -> Tensor:
    """Ramp-filter every view (zero-padded, Ram-Lak kernel, apodised): [V, n_bins] -> [V, n_bins]."""
    if filter not in FILTERS:
        raise ValueError(f"fbp.filter must be one of {', '.join(FILTERS)}; got {filter!r}")
    if values.ndim != 2:
        raise ValueError(f"sinogram values must be [n_views, n_bins], got shape {tuple(values.shape)}")
    if not bin_spacing > 0:
        raise ValueError(f"bin_spacing must be > 0, got {bin_spacing}")
    n_bins = values.shape[1]
    n_pad = 1 << max(1, math.ceil(math.log2(2 * n_bins)))
    response = _filter_response(n_pad, filter, values.dtype, values.device) / bin_spacing
    spectrum = torch.fft.rfft(values, n=n_pad, dim=1) * response
    return torch.fft.irfft(spectrum, n=n_pad, dim=1)[:, :n_bins]


def _filter_response(n_pad: int, filter: str, dtype: torch.dtype, device: torch.device) -> Tensor:
    """Frequency response, per unit bin spacing, of the apodised Ram-Lak filter: [n_pad // 2 + 1]."""
    k = torch.arange(n_pad, dtype=torch.float64, device=device)
    k = torch.where(k > n_pad // 2, k - n_pad, k)
    kernel = torch.where(k % 2 == 1, -1.0 / (math.pi * k) ** 2, torch.zeros_like(k))
    kernel[0] = 0.25
    ramp = torch.fft.rfft(kernel).real
    nu = torch.fft.rfftfreq(n_pad, dtype=torch.float64, device=device)
    windows = {
        "ramp": torch.ones_like(nu),
        "shepp-logan": torch.sinc(nu),
        "cosine": torch.cos(math.pi * nu),
        "hamming": 0.54 + 0.46 * torch.cos(2 * math.pi * nu),
        "hann": 0.5 + 0.5 * torch.cos(2 * math.pi * nu),
    }
    return (ramp * windows[filter]).to(dtype)


def backproject(
    filtered: Tensor, angles: Tensor, weights: Tensor, grid: ImageGrid, bin_spacing: float
) -> Tensor:
    """Weighted sum of every view smeared back along its rays (linear in s): [V, n_bins] -> [H, W]."""
    image = torch.zeros(grid.size, grid.size, dtype=filtered.dtype, device=filtered.device)
    weighted = filtered * weights.to(filtered)[:, None]
    for _, views in _view_backprojections(weighted, angles, grid, bin_spacing):
        image += views.sum(dim=0)
    return image


def _view_backprojections(filtered: Tensor, angles: Tensor, grid: ImageGrid, bin_spacing: float):
    """Yield (first view, [Vc, H, W]) backprojections of consecutive chunks of views, one image per view."""
    n_views, n_bins = filtered.shape
    x, y = grid.xy()
    # grid_sample on a [1, n_bins] strip: normalised coordinate 2 s / (n_bins * bin_spacing).
    scale = 2.0 / (n_bins * bin_spacing)
    cols = torch.from_numpy(x[0] * scale).to(filtered)
    rows = torch.from_numpy(y[:, 0] * scale).to(filtered)
    chunk = max(1, _CHUNK_SAMPLES // grid.size**2)
    # One sampling grid reused by every chunk; its second (row) coordinate stays 0.
    strip_grid = filtered.new_zeros(min(chunk, n_views), grid.size, grid.size, 2)
    for start in range(0, n_views, chunk):
        theta = angles[start : start + chunk].to(filtered)[:, None]
        sample_at = strip_grid[: theta.shape[0]]
        along_cols, along_rows = cols * torch.cos(theta), rows * torch.sin(theta)
        torch.add(along_cols[:, None, :], along_rows[:, :, None], out=sample_at[..., 0])
        strips = filtered[start : start + chunk, None, None, :]
        yield start, F.grid_sample(strips, sample_at, align_corners=False)[:, 0]


def _view_weights(angles: np.ndarray) -> np.ndarray:
    """Angular width of every view (midpoint rule; handles non-uniform spacing): [V] float64."""
    if angles.ndim != 1 or angles.shape[0] < 2 or not np.all(np.isfinite(angles)):
        raise ValueError(f"angles must be a finite 1-D array of >= 2 views, got shape {angles.shape}")
    unwrapped = np.unwrap(angles)
    steps = np.diff(unwrapped)
    if not (np.all(steps > 0) or np.all(steps < 0)):
        raise ValueError("angles must be strictly monotonic (views in acquisition order)")
    return np.abs(np.gradient(unwrapped))


def _half_turn_scale(coverage: np.ndarray | float) -> np.ndarray | float:
    """Scale that brings data covering more than 180 degrees to the 180-degree normalisation."""
    return math.pi / np.maximum(math.pi, coverage)


def fbp(
    values: np.ndarray | Tensor,
    angles: np.ndarray | Tensor,
    grid: ImageGrid,
    bin_spacing: float,
    filter: str = "ramp",
) -> np.ndarray:
    """Filtered backprojection of views spanning 180 or 360 degrees: values [V, n_bins] -> [H, W] f32."""
    values_t = torch.as_tensor(values, dtype=torch.float32)
    angles_np = np.asarray(angles.cpu() if isinstance(angles, Tensor) else angles, dtype=np.float64)
    if values_t.ndim != 2 or values_t.shape[0] != angles_np.shape[0]:
        raise ValueError(
            f"values must be [n_views, n_bins] with one angle per view, got {tuple(values_t.shape)}"
            f" and angles {angles_np.shape}"
        )
    weights = _view_weights(angles_np)
    weights = weights * _half_turn_scale(weights.sum())
    with torch.no_grad():
        filtered = filter_sinogram(values_t, bin_spacing, filter)
        image = backproject(filtered, torch.from_numpy(angles_np), torch.from_numpy(weights), grid, bin_spacing)
    return image.numpy().astype(np.float32)


def fbp_frames(
    sino: Sinogram,
    grid: ImageGrid,
    times: np.ndarray,
    window_deg: float = 180.0,
    filter: str = "ramp",
) -> np.ndarray:
    """FBP at each time from the views spanning ``window_deg`` centred on the nearest view: [F, H, W] f32.

    Any geometry: ``sino`` is first rebinned onto centred parallel rays (``rebin.to_parallel``).
    Windows are clamped inside the acquisition. Every view is filtered and backprojected once; a
    window is the difference of two running sums over views.
    """
    if not 0 < window_deg <= 360:
        raise ValueError(f"fbp.window_deg must be in (0, 360], got {window_deg}")
    sino = to_parallel(sino)
    times = np.asarray(times, dtype=np.float64)
    if times.ndim != 1 or not np.all(np.isfinite(times)):
        raise ValueError(f"times must be a finite 1-D array, got shape {times.shape}")
    weights = _view_weights(np.asarray(sino.angles, dtype=np.float64))
    cumulative = np.concatenate(([0.0], np.cumsum(weights)))
    starts, ends = _windows(cumulative, np.asarray(sino.times, dtype=np.float64), times, math.radians(window_deg))
    scales = _half_turn_scale(cumulative[ends] - cumulative[starts])
    with torch.no_grad():
        filtered = filter_sinogram(torch.as_tensor(sino.values, dtype=torch.float32), sino.geometry.bin_spacing, filter)
        weighted = filtered * torch.from_numpy(weights).float()[:, None]
        angles = torch.as_tensor(np.asarray(sino.angles, dtype=np.float64))
        frames = _window_sums(weighted, angles, grid, sino.geometry.bin_spacing, starts, ends)
    return (frames * torch.from_numpy(scales).to(frames)[:, None, None]).numpy()


def _windows(
    cumulative: np.ndarray, view_times: np.ndarray, times: np.ndarray, span: float
) -> tuple[np.ndarray, np.ndarray]:
    """First and one-past-last view of the window for every time: ([F], [F]) int.

    ``cumulative`` [V + 1] is the angle covered by views [0, v). The window covers ``span``
    radians, centred on the view nearest in time, shifted to stay inside the acquisition;
    all views when the acquisition covers less.
    """
    weights = np.diff(cumulative)
    n_views = weights.shape[0]
    if cumulative[-1] < span - 0.5 * weights.min():
        warnings.warn(
            f"the acquisition covers {math.degrees(cumulative[-1]):.1f} deg of gantry angle, less than"
            f" fbp.window_deg = {math.degrees(span):.1f}: every FBP frame uses all views",
            stacklevel=3,
        )
        return np.zeros(times.shape, dtype=int), np.full(times.shape, n_views)
    after = np.clip(np.searchsorted(view_times, times), 1, n_views - 1)
    nearest = np.where(times - view_times[after - 1] <= view_times[after] - times, after - 1, after)
    centre = cumulative[nearest] + weights[nearest] / 2
    low = np.clip(centre - span / 2, 0.0, cumulative[-1] - span)
    index = np.arange(n_views + 1)
    # Round half up (with slack for float error) so even-length windows shift consistently.
    starts = np.floor(np.interp(low, cumulative, index) + 0.5 + 1e-6).astype(int)
    ends = np.floor(np.interp(cumulative[starts] + span, cumulative, index) + 0.5 + 1e-6).astype(int)
    return starts, np.minimum(ends, n_views)


def _window_sums(
    weighted: Tensor, angles: Tensor, grid: ImageGrid, bin_spacing: float, starts: np.ndarray, ends: np.ndarray
) -> Tensor:
    """Sum of view backprojections over views [start, end) for every window: [F, H, W].

    Chunk by chunk, views are summed between consecutive window boundaries; a running float64
    sum of those segments gives the prefix sum at each boundary, added to or taken from its frames.
    """
    frames = weighted.new_zeros(len(starts), grid.size, grid.size)
    running = torch.zeros(grid.size * grid.size, dtype=torch.float64)
    bounds = np.unique(np.concatenate((starts, ends)))
    for first, views in _view_backprojections(weighted, angles, grid, bin_spacing):
        last = first + views.shape[0]
        local = np.union1d(bounds[(bounds > first) & (bounds < last)], [last])
        # prefix[j] sums views [0, local[j]): this chunk's share by a 0/1 matrix product.
        include = torch.from_numpy(np.arange(first, last)[None, :] < local[:, None]).to(views)
        prefix = running + (include @ views.reshape(views.shape[0], -1)).double()
        for frame_bounds, sign in ((ends, 1.0), (starts, -1.0)):
            hit = np.flatnonzero((frame_bounds > first) & (frame_bounds <= last))
            at = np.searchsorted(local, frame_bounds[hit])
            frames[hit] += sign * prefix[at].to(frames).reshape(-1, grid.size, grid.size)
        running = prefix[-1]
    return frames
