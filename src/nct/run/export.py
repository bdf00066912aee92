"""Files a run leaves for people and other tools: frames (.npz, .tiff), PNG strips, GIF movies."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import imageio.v3 as iio  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import tifffile  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.image import AxesImage  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from nct.run.metrics import FrameMetrics  # noqa: E402


def save_reconstruction(path: Path, times: np.ndarray, extent: float, frames: dict[str, np.ndarray]) -> None:
    """``reconstruction.npz``: each method's frames [F,H,W] float32 (``fbp``, ``nct``), ``times`` [F], ``extent``."""
    arrays = {name: np.asarray(f, dtype=np.float32) for name, f in frames.items()}
    np.savez_compressed(path, times=np.asarray(times, dtype=np.float64), extent=np.float64(extent), **arrays)


def save_tiffs(folder: Path, frames: dict[str, np.ndarray]) -> None:
    """One float32 TIFF stack per method, ``<folder>/<name>.tiff`` [F,H,W] (ImageJ reads it as a movie)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, f in frames.items():
        tifffile.imwrite(folder / f"{name}.tiff", np.asarray(f, dtype=np.float32), imagej=True,
                         metadata={"axes": "TYX"})


def _display_range(frames: dict[str, np.ndarray]) -> float:
    ref = frames.get("truth", next(iter(frames.values())))
    return float(max(np.percentile(ref, 99.9), 1e-6)) * 1.2


def save_strip(path: Path, frames: dict[str, np.ndarray], times: np.ndarray, n_columns: int) -> None:
    """A grid of images: one row per method, ``n_columns`` frames evenly spread over time."""
    idx = np.unique(np.linspace(0, len(times) - 1, min(n_columns, len(times))).round().astype(int))
    vmax = _display_range(frames)
    fig, axes = plt.subplots(len(frames), len(idx), figsize=(1.6 * len(idx), 1.7 * len(frames)), squeeze=False)
    for r, (name, f) in enumerate(frames.items()):
        for c, i in enumerate(idx):
            ax = axes[r, c]
            ax.imshow(f[i], cmap="gray", vmin=0, vmax=vmax)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"t={times[i] * 1e3:.0f} ms", fontsize=8)
            if c == 0:
                ax.set_ylabel(name, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def movie_figure(frames: dict[str, np.ndarray], times: np.ndarray) -> tuple[Figure, list[AxesImage], Text]:
    """The movie's figure, laid out once: a panel per method (truth | FBP | NCT) labelled with its name,
    and above them a time label sized for the longest time. Returns the figure, the panels' images
    and the time label, for `save_movie` to update per frame."""
    vmax = _display_range(frames)
    fig, axes = plt.subplots(1, len(frames), figsize=(2.4 * len(frames), 2.9), squeeze=False, layout="constrained")
    images = []
    for ax, (name, f) in zip(axes[0], frames.items()):
        images.append(ax.imshow(f[0], cmap="gray", vmin=0, vmax=vmax))
        ax.set_title(name, fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
    label = fig.suptitle(_time_label(float(np.max(times))), fontsize=9)
    fig.canvas.draw()  # constrained layout makes room for the label and the panel titles ...
    fig.set_layout_engine("none")  # ... once: the panels stay put from frame to frame
    return fig, images, label


def _time_label(t: float) -> str:
    return f"t = {t * 1e3:.0f} ms"


def save_movie(path: Path, frames: dict[str, np.ndarray], times: np.ndarray, fps: float) -> None:
    """An animated GIF of the methods side by side (truth | FBP | NCT), labelled, looping."""
    fig, images, label = movie_figure(frames, times)
    pictures = []
    for i, t in enumerate(times):
        for im, f in zip(images, frames.values()):
            im.set_data(f[i])
        label.set_text(_time_label(t))
        fig.canvas.draw()
        pictures.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    plt.close(fig)
    iio.imwrite(path, np.stack(pictures), extension=".gif", duration=1000.0 / fps, loop=0)


def save_metric_plot(path: Path, times: np.ndarray, metrics: dict[str, FrameMetrics]) -> None:
    """Dice and MSE of every method against time."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.2))
    for name, m in metrics.items():
        a1.plot(times * 1e3, m.dice, label=name)
        a2.plot(times * 1e3, m.mse, label=name)
    a1.set(xlabel="time (ms)", ylabel="Dice", ylim=(0, 1.02))
    a2.set(xlabel="time (ms)", ylabel="MSE", yscale="log")
    a1.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def save_trace_plot(path: Path, trace: list[dict], fbp_dice: float) -> None:
    """The run's Dice-against-time curve: median Dice of each snapshot (``trace.csv`` rows) against
    seconds into the reconstruction, one colour per stage, FBP's median Dice as a line."""
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for stage in dict.fromkeys(r["stage"] for r in trace):
        rows = [r for r in trace if r["stage"] == stage]
        ax.plot([r["seconds"] for r in rows], [r["median_dice"] for r in rows], marker=".", label=stage)
    ax.axhline(fbp_dice, color="grey", linestyle="--", label="FBP")
    ax.set(xlabel="seconds into the reconstruction", ylabel="median Dice", ylim=(0, 1.02))
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
