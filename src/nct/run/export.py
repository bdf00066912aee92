"""Files a run leaves for people and other tools: TIFF stacks, PNG strips, GIF movies (the frames' .npz:
run/reconstruction.py).

Each picture is built by a function returning its matplotlib Figure (titled, axes labelled with
units, a colourbar for images, legends outside the axes so they cover no data), then saved.
"""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np
import tifffile
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.text import Text
from matplotlib.ticker import MaxNLocator

from nct.run.metrics import FrameMetrics

#: Axis and colourbar labels: the data carry no unit names, so lengths are in the unit of the field
#: of view (``extent``, the sinogram file's length unit) and intensities in the data's own unit.
X_LABEL, Y_LABEL = "x (length unit of the data)", "y (length unit of the data)"
INTENSITY_LABEL = "intensity (the data's unit)"
MSE_LABEL = "MSE (intensity unit²)"
TIME_LABEL = "frame time (ms)"
TIFF_UNIT = "unit"  # ImageJ's name of the length unit of the TIFFs' pixel size: the data's, unnamed


def save_tiffs(folder: Path, frames: dict[str, np.ndarray], times: np.ndarray, extent: float) -> None:
    """One float32 TIFF stack per method, ``<folder>/<name>.tiff`` [F,H,W], which ImageJ reads as a movie
    with its pixel size (``extent`` / W, in the data's length unit, which no file names: `TIFF_UNIT`) and
    frame interval (s; the mean of ``times`` [F]' steps, absent for one frame)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, f in frames.items():
        pixel = extent / f.shape[-1]
        metadata = {"axes": "TYX", "unit": TIFF_UNIT} | (
            {"finterval": float(np.mean(np.diff(times)))} if len(times) > 1 else {})
        tifffile.imwrite(folder / f"{name}.tiff", np.asarray(f, dtype=np.float32), imagej=True,
                         resolution=(1 / pixel, 1 / pixel), metadata=metadata)


def _display_range(frames: dict[str, np.ndarray]) -> float:
    ref = frames.get("truth", next(iter(frames.values())))
    return float(max(np.percentile(ref, 99.9), 1e-6)) * 1.2


def _save(fig: Figure, path: Path, dpi: int = 100) -> None:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=dpi)


def _image_extent(extent: float) -> tuple[float, float, float, float]:
    """imshow's (left, right, bottom, top) for a square field of view of side ``extent`` centred on 0;
    row 0 of a frame is its top (largest y)."""
    return -extent / 2, extent / 2, -extent / 2, extent / 2


#: The strip's layout in inches: each frame's side, the blank between frames (a share of it) and
#: between rows, and the margins around the rows (labels, the time above each column, the colourbar).
STRIP_FRAME_IN, STRIP_GAP, STRIP_ROW_GAP_IN = 1.5, 0.08, 0.12
STRIP_MARGINS_IN = {"left": 1.0, "right": 1.2, "top": 0.5, "bottom": 0.5}


def strip_figure(frames: dict[str, np.ndarray], times: np.ndarray, n_columns: int, extent: float) -> Figure:
    """A grid of images: one row per method (name [F,H,W]), ``n_columns`` frames evenly spread over
    ``times`` [F] s, each row one image of its frames side by side (drawn at once, laid out by hand: a
    fraction of the time of a panel per frame); axes in the data's length unit, each frame's own over
    the field of view of side ``extent``; one shared grey scale with its colourbar."""
    idx = np.unique(np.linspace(0, len(times) - 1, min(n_columns, len(times))).round().astype(int))
    vmax = _display_range(frames)
    size = next(iter(frames.values())).shape[-1]
    gap = max(1, round(STRIP_GAP * size))  # blank pixels between frames
    step = (size + gap) * extent / size  # from one frame's centre to the next, in length units
    n, rows, m = len(idx), len(frames), STRIP_MARGINS_IN
    row_in = STRIP_FRAME_IN * (n * size + (n - 1) * gap) / size
    width = m["left"] + row_in + m["right"]
    height = m["top"] + rows * STRIP_FRAME_IN + (rows - 1) * STRIP_ROW_GAP_IN + m["bottom"]
    fig = Figure(figsize=(width, height))
    # Ticks inside each frame only: a tick on its edge would run into the next frame's label.
    ticks = [t for t in MaxNLocator(4).tick_values(-extent / 2, extent / 2) if abs(t) < 0.45 * extent]
    centres = step * np.arange(n)
    for r, (name, f) in enumerate(frames.items()):
        bottom = m["bottom"] + (rows - 1 - r) * (STRIP_FRAME_IN + STRIP_ROW_GAP_IN)
        ax = fig.add_axes((m["left"] / width, bottom / height, row_in / width, STRIP_FRAME_IN / height))
        image = ax.imshow(_side_by_side(f[idx], gap), cmap="gray", vmin=0, vmax=vmax,
                          extent=(-extent / 2, centres[-1] + extent / 2, -extent / 2, extent / 2))
        last = r == rows - 1
        labels = [f"{t:g}" for _ in centres for t in ticks] if last else []
        ax.set_xticks([c + t for c in centres for t in ticks], labels)
        ax.set_yticks(ticks, [f"{t:g}" for t in ticks])
        ax.tick_params(labelsize=6)
        ax.set_ylabel(name, fontsize=9)
        if r == 0:
            for c, i in zip(centres, idx):
                ax.annotate(f"t = {times[i] * 1e3:.0f} ms", (c, extent / 2), xytext=(0, 3), textcoords="offset points",
                            ha="center", va="bottom", fontsize=8)
    bar = fig.add_axes(((width - m["right"] + 0.35) / width, m["bottom"] / height, 0.15 / width,
                        (height - m["top"] - m["bottom"]) / height))
    fig.colorbar(image, cax=bar, label=INTENSITY_LABEL)
    fig.supxlabel(X_LABEL, fontsize=8)
    fig.supylabel(Y_LABEL, fontsize=8)
    fig.suptitle(f"{', '.join(frames)}: frames over time (rows: method)", fontsize=9)
    return fig


def _side_by_side(frames: np.ndarray, gap: int) -> np.ndarray:
    """Frames [N, H, W] in one image [H, N W + (N - 1) gap], NaN (drawn blank) in the ``gap`` columns between them."""
    n, h, w = frames.shape
    row = np.full((h, n * w + (n - 1) * gap), np.nan, dtype=np.float32)
    for i, f in enumerate(frames):
        row[:, i * (w + gap):i * (w + gap) + w] = f
    return row


def save_strip(path: Path, frames: dict[str, np.ndarray], times: np.ndarray, n_columns: int, extent: float) -> None:
    """`strip_figure` as a PNG."""
    _save(strip_figure(frames, times, n_columns, extent), path)


def movie_figure(frames: dict[str, np.ndarray], times: np.ndarray, extent: float
                 ) -> tuple[Figure, list[AxesImage], Text]:
    """The movie's figure, laid out once: a panel per method (truth | FBP | NCT) labelled with its name,
    axes in the data's length unit, one colourbar, and above them a time label sized for the longest
    time. Returns the figure, the panels' images and the time label, for `save_movie` to update per frame."""
    vmax = _display_range(frames)
    fig = Figure(figsize=(2.4 * len(frames) + 1.0, 3.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(frames), squeeze=False, sharey=True)[0]
    images = []
    for ax, (name, f) in zip(axes, frames.items()):
        images.append(ax.imshow(f[0], cmap="gray", vmin=0, vmax=vmax, extent=_image_extent(extent)))
        ax.set_title(name, fontsize=10)
        ax.tick_params(labelsize=6)
    fig.supxlabel(X_LABEL, fontsize=7)
    fig.supylabel(Y_LABEL, fontsize=7)
    fig.colorbar(images[0], ax=axes, label=INTENSITY_LABEL, shrink=0.9)
    label = fig.suptitle(time_label(float(np.max(times))), fontsize=9)
    fig.canvas.draw()  # constrained layout makes room for the label and the panel titles ...
    fig.set_layout_engine("none")  # ... once: the panels stay put from frame to frame
    return fig, images, label


def time_label(t: float) -> str:
    """The movie's label for time ``t`` (s)."""
    return f"t = {t * 1e3:.0f} ms"


def movie_pictures(frames: dict[str, np.ndarray], times: np.ndarray, extent: float) -> np.ndarray:
    """The movie's pictures [F, H, W, 3] uint8 (`movie_figure` at each of ``times`` [F] s). What stays put
    is drawn once; each frame then redraws only the panels' images, their spines and the time label on
    that background: the same pixels as a full draw per frame, in a fifth of the time at 48 frames."""
    fig, images, label = movie_figure(frames, times, extent)
    # Spines too: drawn on the background as well, their antialiased edges would be blended twice.
    changing = [*images, label, *(spine for im in images for spine in im.axes.spines.values())]
    for artist in changing:
        artist.set_visible(False)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    for artist in changing:
        artist.set_visible(True)
    pictures = []
    for i, t in enumerate(times):
        fig.canvas.restore_region(background)
        for im, f in zip(images, frames.values()):
            im.set_data(f[i])
            im.axes.draw_artist(im)
            for spine in im.axes.spines.values():
                im.axes.draw_artist(spine)
        label.set_text(time_label(t))
        fig.draw_artist(label)
        pictures.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    return np.stack(pictures)


def save_movie(path: Path, frames: dict[str, np.ndarray], times: np.ndarray, fps: float, extent: float) -> None:
    """An animated GIF of the methods side by side (truth | FBP | NCT), labelled, looping. Pictures all grey
    (a grey scale, black text: unless a matplotlib style colours them) are written as grey levels: the same
    pixels, without the quantisation to a palette that took most of the time."""
    pictures = movie_pictures(frames, times, extent)
    grey = bool((pictures[..., :1] == pictures[..., 1:]).all())
    iio.imwrite(path, pictures[..., 0] if grey else pictures, extension=".gif", duration=1000.0 / fps, loop=0)


#: The panels of `metric_figure`: FrameMetrics field, axis label, log scale.
METRIC_PANELS = (("dice", "Dice (1 = masks equal)", False), ("ssim", "SSIM (1 = images equal)", False),
                 ("mse", MSE_LABEL, True), ("psnr", "PSNR (dB, over the truth's range)", False))


def metric_figure(times: np.ndarray, metrics: dict[str, FrameMetrics]) -> Figure:
    """Each method's scores against the truth per frame (``times`` [F] s): Dice, SSIM, MSE, PSNR;
    one legend outside the panels. Laid out by hand (a layout engine took a third of its time)."""
    fig = Figure(figsize=(9.5, 5.5))
    fig.subplots_adjust(left=0.08, right=0.87, bottom=0.09, top=0.92, wspace=0.28, hspace=0.3)
    for ax, (field, label, log) in zip(fig.subplots(2, 2).ravel(), METRIC_PANELS):
        for name, m in metrics.items():
            ax.plot(times * 1e3, getattr(m, field), marker=".", label=name)
        ax.set(xlabel=TIME_LABEL, ylabel=label, yscale="log" if log else "linear")
        if field == "dice":
            ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
    fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="upper left", bbox_to_anchor=(0.88, 0.92), title="method")
    fig.suptitle("Each frame against the truth (Dice at half the faintest true intensity)", fontsize=10)
    return fig


def save_metric_plot(path: Path, times: np.ndarray, metrics: dict[str, FrameMetrics]) -> None:
    """`metric_figure` as a PNG."""
    _save(metric_figure(times, metrics), path)


def trace_figure(trace: list[dict], fbp_dice: float) -> Figure:
    """The run's Dice-against-time curve: median Dice of each snapshot (``trace.csv`` rows) against
    seconds into the reconstruction, one colour per stage, FBP's median Dice as a line; legend outside."""
    fig = Figure(figsize=(6.5, 3.4), layout="constrained")
    ax = fig.subplots()
    for stage in dict.fromkeys(r["stage"] for r in trace):
        rows = [r for r in trace if r["stage"] == stage]
        ax.plot([r["seconds"] for r in rows], [r["median_dice"] for r in rows], marker=".", label=stage)
    ax.axhline(fbp_dice, color="grey", linestyle="--", label="FBP")
    ax.set(xlabel="time into the reconstruction (s)", ylabel="median Dice over frames", ylim=(0, 1.02))
    ax.grid(alpha=0.3)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside right upper", title="stage", fontsize=8)
    fig.suptitle("NeuralCT's median Dice during the fit", fontsize=10)
    return fig


def save_trace_plot(path: Path, trace: list[dict], fbp_dice: float) -> None:
    """`trace_figure` as a PNG."""
    _save(trace_figure(trace, fbp_dice), path)
