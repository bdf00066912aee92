"""The memory a run would need, refused before allocating where it exceeds this machine's: from the
sizes of the arrays that set a run's peak (frames, sinogram), a simulation's at validation, a file's
once read."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from nct.acquisition.scanner import ImageGrid
from nct.errors import InputError
from nct.run.conf import SimulateConf
from nct.run.schema import NCTConf

# Bytes per element of the arrays that set a run's peak memory; measured as the peak RSS of
# `nct debug=tiny threads=1` above that at image.size=64 (1 object; more objects need more).
RASTER_BYTES = 1150  # per pixel, simulated truth at 4x4 supersampling: ~9 float64 sub-pixel arrays (1165 at size 1024)
FIT_BYTES = 128  # per pixel and view of a NeuralCT step: render and gradients (133 at size 512, optim.batch_views=20)
FRAME_BYTES = 16  # per pixel and output frame: truth, FBP and NeuralCT frames (17 at size 512, 6 vs 60 frames)
VIEW_BYTES = 16  # per view and detector bin: the sinogram and its filtered and weighted copies


@dataclass(frozen=True)
class RunSize:
    """The arrays that set a run's memory: frames [n_frames, size, size], sinogram [n_views, n_bins]."""

    size: int
    n_frames: int
    n_views: int
    n_bins: int


def check_memory(conf: NCTConf, run: RunSize, image_key: str, data_key: str) -> None:
    """Refuse, before allocating, a run whose largest arrays exceed this machine's physical memory,
    naming ``image_key`` (what sets the image size) or ``data_key`` (the sinogram's), whichever costs
    more. Physical memory, not the memory free now: no run can pass it, while what is free changes
    with the jobs beside this one (a sweep's). A fit's render and gradients are sized by the grid it fits
    (``optim.fit_size``: a large image fitted on a smaller one)."""
    total = physical_memory()
    fitted = run.size // ImageGrid(run.size).fit_factor(conf.optim.fit_size, run.n_bins)  # the fit's own grid
    per_pixel = RASTER_BYTES * isinstance(conf.data, SimulateConf) + FRAME_BYTES * run.n_frames
    fit = FIT_BYTES * conf.optim.batch_views * (conf.method == "nct") * fitted**2
    image, sinogram = run.size**2 * per_pixel + fit, VIEW_BYTES * run.n_views * run.n_bins
    if total is not None and image + sinogram > total:
        raise InputError(f"{image_key if image >= sinogram else data_key}: the run would need about "
                         f"{binary_size(image + sinogram)} of memory ({run.size}x{run.size} pixels, {run.n_frames} "
                         f"frames, {run.n_views} views x {run.n_bins} bins), more than this machine's "
                         f"{binary_size(total)}")


def physical_memory() -> int | None:
    """This machine's memory in bytes; None where the system does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):  # no sysconf (Windows) or no such name
        return None


def binary_size(n_bytes: float) -> str:
    """``n_bytes`` in KiB ... PiB, three significant digits."""
    exponent = min(max(int(math.log(max(n_bytes, 1), 1024)), 1), 5)
    return f"{n_bytes / 1024**exponent:.3g} {'KMGTP'[exponent - 1]}iB"
