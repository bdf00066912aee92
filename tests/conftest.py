"""The one shared test module: the real Hydra config composed in-process and shrunk to tiny sizes,
tiny method settings and scenes, closed-form geometry cases, an independent reference projector and
the loader of benchmarks/ scripts.

The ``nct`` command run in-process (``nct`` fixture: exit code, stdout, stderr).

Shared by the method tests: a tiny model and short fits, and a tiny moving-disc acquisition.

Shared by the geometry tests: every geometry the projector, simulation and FBP must handle, and
the closed-form line integrals of ellipses along their rays, derived from the convention in
docs/DATA.md ("Geometry: parallel and fan beam") independently of ``nct.acquisition.geometry``.

An independent reference projector for the tests: exact ray–pixel intersection lengths (Siddon's
method) of a pixel image, along rays whose end points are derived here from the documented convention
(docs/DATA.md "Geometry: parallel and fan beam"), not from ``nct.acquisition.geometry``.

Convention: a point (x, y), x right, y up, origin at the image centre; pixel (row, col) of N covers
x in [col, col + 1]·extent/N − extent/2 and y in [N − row − 1, N − row]·extent/N − extent/2. At view
angle θ, d = (−sin θ, cos θ), e = (cos θ, sin θ); bin i at u_i = (i − (n − 1)/2)·bin_spacing + offset.
Parallel: the ray through u·e along d. Fan: from the source −D·d to the flat detector point
D_d·d + u·e, or on the curved detector at fan angle γ = u/(D + D_d) from the central ray, i.e. the
point −D·d + (D + D_d)(cos γ·d + sin γ·e).

Shared by the figure tests (run/export.py, analysis/report_figures.py): `figure_problems`, what a
figure lacks to explain itself.
"""

from __future__ import annotations

import copy
import csv
import functools
import importlib.util
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_module
from hydra.core.global_hydra import GlobalHydra
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.figure import Figure
from omegaconf import DictConfig
from skimage.transform import radon
from threadpoolctl import threadpool_limits

from nct.acquisition.geometry import FanGeometry, ParallelGeometry
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.sinogram import Sinogram
from nct.cli import main as cli
from nct.cli.main import CONFIG_MODULE
from nct.fields.conf import ModelConf
from nct.fit.conf import CallbacksConf, LossConf, OptimConf, TrainerArgs, TrainerConf
from nct.init.conf import BackgroundConf, InitConf
from nct.method.reconstruct import reconstruct
from nct.scenes.phantoms import CircleConf, ComposedConf, build_phantom
from nct.scenes.signals import EllipseConf, Signal
from nct.scenes.simulate import simulate
from nct.select.conf import SelectionConf

TINY = [
    "image.size=32",
    "image.frames_per_rotation=6",
    "scanner.views_per_rotation=60",
    "scanner.n_bins=32",
    "optim.init_steps=5",
    "optim.fit_steps=5",
    "optim.refine=false",
    "export.strip_frames=3",
    "data.n_objects=1",  # the scene given: these runs test the pipeline's mechanics, not the choice of model
    "background=none",
]


def compose_config(overrides: list[str], with_hydra: bool = False) -> DictConfig:
    """The primary config with ``overrides``, as ``nct`` composes it from the package's configs
    (with its ``hydra`` node when ``with_hydra``); each caller gets its own copy of it."""
    return copy.deepcopy(_composed(tuple(overrides), with_hydra))


@functools.cache
def _composed(overrides: tuple[str, ...], with_hydra: bool) -> DictConfig:
    """`compose_config`'s config, composed once a worker: a composition takes Hydra 0.5 s, and the suite
    composed 145 times, 20 of them a config composed before (session 59)."""
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module(config_module=CONFIG_MODULE, version_base="1.3"):
            return compose(config_name="config", overrides=list(overrides), return_hydra_config=with_hydra)
    finally:
        GlobalHydra.instance().clear()


@pytest.fixture(autouse=True, scope="session")
def one_thread() -> Iterator[None]:
    """One torch thread and one BLAS thread for the whole suite: a fit's numbers depend on the thread
    count, and in-process CLI runs would otherwise change it from one test to the next; BLAS threads
    on the suite's small matrices only wait for each other, and on a busy machine a 158² Cholesky
    took 26 ms with two against 0.3 ms with one (moments/trajectory.py's evidence search: 14 s, 0.15 s)."""
    torch.set_num_threads(1)
    with threadpool_limits(1):
        yield


DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


@pytest.fixture(params=DEVICES)
def device(request) -> torch.device:
    """Each device this machine has: a test taking it runs on the CPU and, where there is one, on a CUDA GPU."""
    return torch.device(request.param)


@pytest.fixture
def tiny_cfg():
    """A factory: tiny config with extra overrides."""
    return lambda *extra: compose_config(TINY + list(extra))


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    return tmp_path / "run"


@pytest.fixture
def nct(tmp_path, monkeypatch, capsys):
    """Run ``nct ARGS`` in-process in ``tmp_path``; return (exit code, stdout, stderr)."""
    monkeypatch.chdir(tmp_path)

    def call(*args: str) -> tuple[int, str, str]:
        monkeypatch.setattr(sys, "argv", ["nct", *args])
        GlobalHydra.instance().clear()
        try:
            cli.main()
            code = 0
        except SystemExit as done:
            code = done.code
        finally:
            GlobalHydra.instance().clear()
        out = capsys.readouterr()
        return code, out.out, out.err

    return call


MODEL = ModelConf(width=16, depth=2, temporal_width=16, temporal_depth=2, n_terms=8)
TRAINER = TrainerConf(TrainerArgs(accelerator="cpu"), CallbacksConf(progress_bar=False))
OPTIM = OptimConf(init_steps=30, fit_steps=40, refine=False, batch_views=8, warmup_steps=5, lr_decay_every=20)
INIT = InitConf(frames_per_rotation=12)
NO_BACKGROUND = BackgroundConf(name="none")  # the paper's scene: K objects on an empty background, nothing chosen


def moving_disc(grid: ImageGrid = ImageGrid(32)) -> tuple[Sinogram, np.ndarray]:
    """A disc (radius 0.2) orbiting at 60 deg/rotation, 60 views of 32 bins, noiseless; and 6 frame times."""
    scanner = Scanner(views_per_rotation=60, rotations=1.0, rotation_time=0.25, n_bins=32, bin_spacing=1 / 32)
    phantom = build_phantom(CircleConf(radius=0.2, orbit_radius=0.15, displacement_deg=60.0), scanner.rotation_time)
    times = scanner.frame_times(6)
    return simulate(phantom, scanner, grid, times, None, np.random.default_rng(0)), times


def circle(deg: float, rotations: float = 1.0, views: int = 720, size: int = 128) -> tuple[Sinogram, np.ndarray, float]:
    """The project's circle (conf/phantom/circle.yaml) at ``deg``/rot, simulated analytically:
    (sinogram, true centre at every view [V, 2], pixel size)."""
    scanner = Scanner(views_per_rotation=views, rotations=rotations, n_bins=size, bin_spacing=1 / size)
    phantom = build_phantom(CircleConf(displacement_deg=deg), scanner.rotation_time)
    sino = simulate(phantom, scanner, ImageGrid(size), scanner.frame_times(1), None, np.random.default_rng(0))
    return sino, phantom.ellipses(scanner.times)[:, 0, :2], 1 / size



def fit_composed(objects: list, grid: ImageGrid, optim: OptimConf, noise_i0: float | None = None,
                 motion: SelectionConf | None = None, seed: int = 0):
    """A composed scene of ``objects`` (phantoms.EllipseConf), 120 views of 40 bins, 6 frames,
    simulated analytically and reconstructed with K = len(objects), the fit seeded by ``seed``:
    (sinogram, times, NCTResult)."""
    scanner = Scanner(views_per_rotation=120, rotations=1.0, rotation_time=0.25, n_bins=40, bin_spacing=1 / 40)
    phantom = build_phantom(ComposedConf(objects=objects), scanner.rotation_time)
    times = scanner.frame_times(6)
    sino = simulate(phantom, scanner, grid, times, noise_i0, np.random.default_rng(0))
    result = reconstruct(sino, grid, times, MODEL, LossConf(), TRAINER, seed, log_dir=None, logger="none",
                         n_objects=len(objects), optim=optim, init=INIT, motion=motion, background=NO_BACKGROUND)
    return sino, times, result


LONGER = replace(OPTIM, fit_steps=200, lr_decay_every=60)


def orbit(radius: float, orbit_radius: float, deg: float, intensity: float) -> EllipseConf:
    """A disc on a circular orbit about the centre, ``deg`` of arc per rotation."""
    c = deg / 360
    return EllipseConf(x=Signal(amplitude=orbit_radius, cycles_per_rotation=c, phase_deg=90.0),
                       y=Signal(amplitude=orbit_radius, cycles_per_rotation=c),
                       a=Signal(radius), b=Signal(radius), intensity=Signal(intensity))


def still(x: float, y: float, a: float, b: float, intensity: float) -> EllipseConf:
    return EllipseConf(x=Signal(x), y=Signal(y), a=Signal(a), b=Signal(b), intensity=Signal(intensity))


def two_object_frames(n_frames: int = 20, noise: float = 0.05, seed: int = 0):
    """Noisy frames of a bright disc (1.0) and a fainter square (0.4) moving apart: images, masks."""
    x, y = ImageGrid(48).xy()
    rng = np.random.default_rng(seed)
    images, masks = [], []
    for f in range(n_frames):
        disc = (x - 0.15 + 0.005 * f) ** 2 + (y - 0.1) ** 2 < 0.15**2
        square = (np.abs(x + 0.2) < 0.1) & (np.abs(y + 0.15 + 0.004 * f) < 0.1)
        images.append(1.0 * disc + 0.4 * square + noise * rng.standard_normal(x.shape))
        masks.append(np.stack([disc, square]))
    return np.stack(images).astype(np.float32), np.stack(masks)


GEOMETRIES = {
    "parallel": ParallelGeometry(96, 1 / 64),
    "parallel-offset": ParallelGeometry(104, 1 / 64, detector_offset=0.06),
    "fan-flat": FanGeometry(128, 0.0125, source_distance=2.0, detector_distance=1.0),
    "fan-curved": FanGeometry(128, 0.0125, source_distance=2.0, detector_distance=1.0, detector_shape="curved"),
    "fan-flat-offset": FanGeometry(144, 0.0125, 2.0, 1.0, "flat", detector_offset=0.1),
    "fan-curved-offset": FanGeometry(144, 0.0125, 2.0, 1.0, "curved", detector_offset=-0.1),
}

# (cx, cy, semi-axis a along direction phi, semi-axis b, phi, intensity): off-centre and rotated.
ELLIPSES = ((0.1, -0.05, 0.32, 0.22, 0.5, 1.0), (-0.18, 0.12, 0.1, 0.06, -0.4, 0.5))


def detector_u(geometry, n_bins: int | None = None) -> np.ndarray:
    """u_i = (i - (n_bins - 1)/2) bin_spacing + detector_offset: [n_bins]."""
    n = geometry.n_bins if n_bins is None else n_bins
    return (np.arange(n) - (n - 1) / 2) * geometry.bin_spacing + geometry.detector_offset


def reference_rays(geometry, angles: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A point on each ray and its unit direction, [V, B, 2] each, straight from the convention:
    parallel rays run along d through u e; fan rays leave the source -D d towards the flat detector
    point Dd d + u e, or at fan angle u / (D + Dd) on the curved one."""
    d = np.stack((-np.sin(angles), np.cos(angles)), -1)[:, None, :]
    e = np.stack((np.cos(angles), np.sin(angles)), -1)[:, None, :]
    u = u[None, :, None]
    if isinstance(geometry, ParallelGeometry):
        return u * e + 0 * d, d + 0 * u
    source = -geometry.source_distance * d + 0 * u
    if geometry.detector_shape == "flat":
        towards = geometry.detector_distance * d + u * e - source
    else:
        gamma = u / (geometry.source_distance + geometry.detector_distance)
        towards = np.cos(gamma) * d + np.sin(gamma) * e
    return source, towards / np.linalg.norm(towards, axis=-1, keepdims=True)


def ellipse_chords(points: np.ndarray, directions: np.ndarray, ellipses) -> np.ndarray:
    """Line integrals of filled ellipses along the lines p + t v ([..., 2] each): [...].

    In each ellipse's frame, |q + t w|_ellipse = 1 is A t^2 + B t + C = 0; the chord is sqrt(B^2 - 4AC) / A.
    """
    total = np.zeros(points.shape[:-1])
    for cx, cy, a, b, phi, value in ellipses:
        c, s = np.cos(phi), np.sin(phi)
        qx, qy = points[..., 0] - cx, points[..., 1] - cy
        q = ((qx * c + qy * s) / a, (-qx * s + qy * c) / b)
        vx, vy = directions[..., 0], directions[..., 1]
        w = ((vx * c + vy * s) / a, (-vx * s + vy * c) / b)
        A = w[0] ** 2 + w[1] ** 2
        B = 2 * (q[0] * w[0] + q[1] * w[1])
        C = q[0] ** 2 + q[1] ** 2 - 1
        total += value * np.sqrt(np.clip(B * B - 4 * A * C, 0, None)) / A
    return total


def closed_form_sinogram(geometry, angles: np.ndarray, ellipses=ELLIPSES, sub_rays: int = 1) -> np.ndarray:
    """Closed-form line integrals averaged over ``sub_rays`` rays evenly across each bin: [V, n_bins]."""
    offsets = ((np.arange(sub_rays) + 0.5) / sub_rays - 0.5) * geometry.bin_spacing
    u = (detector_u(geometry)[:, None] + offsets[None, :]).reshape(-1)
    chords = ellipse_chords(*reference_rays(geometry, angles, u), ellipses)
    return chords.reshape(len(angles), geometry.n_bins, sub_rays).mean(axis=-1)


def ellipse_image(grid: ImageGrid, ellipses=ELLIPSES, supersample: int = 8) -> np.ndarray:
    """Area-averaged intensity of filled ellipses on ``grid``: [H, W] float64."""
    x, y = grid.refined(supersample).xy()
    fine = np.zeros_like(x)
    for cx, cy, a, b, phi, value in ellipses:
        along = (x - cx) * np.cos(phi) + (y - cy) * np.sin(phi)
        across = -(x - cx) * np.sin(phi) + (y - cy) * np.cos(phi)
        fine += value * ((along / a) ** 2 + (across / b) ** 2 <= 1)
    n = grid.size
    return fine.reshape(n, supersample, n, supersample).mean(axis=(1, 3))


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def radon_rows(img: np.ndarray, angles: np.ndarray, pixel_size: float) -> np.ndarray:
    """skimage radon in the sinogram layout [V, n] and line-integral units (centre at n // 2): an
    independent projector to check the scenes' projections against."""
    return radon(img, np.rad2deg(angles), circle=True).T * pixel_size


def ellipse_projection(s: np.ndarray, angles: np.ndarray, ellipses) -> np.ndarray:
    """Closed-form parallel-beam line integrals of filled ellipses at detector positions s: [V, n_bins] float64.

    Along direction theta an ellipse of semi-axes a, b (a at angle phi) has support half-width
    r = sqrt(a^2 cos^2(theta - phi) + b^2 sin^2(theta - phi)) about its centre's s, and chord
    length 2 a b sqrt(r^2 - s'^2) / r^2 at offset s'.
    """
    total = np.zeros((len(angles), len(s)))
    for cx, cy, a, b, phi, value in ellipses:
        offset = s[None, :] - (cx * np.cos(angles) + cy * np.sin(angles))[:, None]
        r2 = ((a * np.cos(angles - phi)) ** 2 + (b * np.sin(angles - phi)) ** 2)[:, None]
        total += value * 2 * a * b * np.sqrt(np.clip(r2 - offset**2, 0, None)) / r2
    return total


def bins(n_bins: int, spacing: float) -> np.ndarray:
    """The bin centres of a centred parallel detector."""
    return Scanner(n_bins=n_bins, bin_spacing=spacing).bin_positions


def dice(a: np.ndarray, b: np.ndarray) -> float:
    return float(2 * (a & b).sum() / (a.sum() + b.sum()))


def ray_end_points(theta: np.ndarray, u: np.ndarray, source_distance: float | None = None,
                   detector_distance: float | None = None, detector_shape: str = "flat",
                   reach: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Start and end points of every ray, ([V, B, 2], [V, B, 2]): parallel rays (no ``source_distance``)
    run from u·e − reach·d to u·e + reach·d; fan rays from the source to the detector."""
    d = np.stack((-np.sin(theta), np.cos(theta)), -1)[:, None, :]
    e = np.stack((np.cos(theta), np.sin(theta)), -1)[:, None, :]
    u = np.asarray(u, dtype=np.float64)[None, :, None]
    if source_distance is None:
        return u * e - reach * d, u * e + reach * d
    source = -source_distance * d + 0 * u
    if detector_shape == "flat":
        return source, detector_distance * d + u * e
    gamma = u / (source_distance + detector_distance)
    return source, source + (source_distance + detector_distance) * (np.cos(gamma) * d + np.sin(gamma) * e)


def siddon(image: np.ndarray, extent: float, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Line integrals of the piecewise-constant ``image`` [N, N] (side ``extent``) along the segments
    start -> end ([..., 2] each): the sum over pixels of value × exact length of the segment inside it."""
    n = image.shape[0]
    shape = start.shape[:-1]
    p1, p2 = start.reshape(-1, 2), end.reshape(-1, 2)
    delta = p2 - p1
    planes = np.linspace(-extent / 2, extent / 2, n + 1)
    # Parameters α in [0, 1] where the segment crosses every vertical and horizontal pixel boundary.
    with np.errstate(divide="ignore", invalid="ignore"):
        crossings = [(planes[None, :] - p1[:, k : k + 1]) / delta[:, k : k + 1] for k in (0, 1)]
    alphas = np.concatenate([np.zeros((len(p1), 1)), np.ones((len(p1), 1)), *crossings], axis=1)
    alphas = np.sort(np.clip(np.nan_to_num(alphas, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0), axis=1)
    lengths = np.diff(alphas, axis=1) * np.linalg.norm(delta, axis=1)[:, None]
    middle = p1[:, None, :] + 0.5 * (alphas[:, 1:] + alphas[:, :-1])[..., None] * delta[:, None, :]
    pixel = extent / n
    col = np.floor((middle[..., 0] + extent / 2) / pixel).astype(int)
    row = np.floor((extent / 2 - middle[..., 1]) / pixel).astype(int)
    inside = (col >= 0) & (col < n) & (row >= 0) & (row < n) & (lengths > 0)
    values = np.where(inside, image[row.clip(0, n - 1), col.clip(0, n - 1)], 0.0)
    return (values * lengths).sum(axis=1).reshape(shape)


BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def write_table(path: Path, columns: tuple, rows: list) -> Path:
    """A CSV table at ``path`` with a header of ``columns`` and ``rows``, as a benchmark writes its tables."""
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        writer.writerows(rows)
    return path


def load_benchmark(path: str):
    """A script of benchmarks/ as a module, by its path there without ``.py`` ("fan",
    "diagnostics/band_race"); the scripts are not part of the package, and import those of their folder."""
    script = BENCHMARKS / f"{path}.py"
    if str(script.parent) not in sys.path:
        sys.path.insert(0, str(script.parent))
    spec = importlib.util.spec_from_file_location(script.stem, script)
    module = importlib.util.module_from_spec(spec)
    sys.modules[script.stem] = module
    spec.loader.exec_module(module)
    return module


def figure_problems(fig: Figure, units: tuple[str, ...] = ()) -> list[str]:
    """What ``fig`` lacks to explain itself (empty when nothing): a title (the figure's, or every
    panel's); x and y labels on every panel (its own or the figure's supxlabel/supylabel); each text of
    ``units`` in some label; a colourbar when it shows images, a legend when it plots curves or points
    (and no image); no plotted point (line vertex, scatter or error-bar point) nor title under a legend."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    problems = []
    bars = [ax for ax in fig.axes if hasattr(ax, "_colorbar")]
    panels = [ax for ax in fig.axes if ax not in bars]
    sup = {name: getattr(fig, f"_sup{name}") for name in ("title", "xlabel", "ylabel")}
    sup = {name: text.get_text() if text is not None else "" for name, text in sup.items()}
    if not sup["title"] and not all(ax.get_title() for ax in panels):
        problems.append("no title")
    for i, ax in enumerate(panels):
        for axis in ("x", "y"):
            if not getattr(ax, f"get_{axis}label")() and not sup[f"{axis}label"]:
                problems.append(f"panel {i} has no {axis} label")
    labels = [sup["xlabel"], sup["ylabel"], *(t for ax in fig.axes for t in (ax.get_xlabel(), ax.get_ylabel()))]
    problems += [f"no label names the unit {unit!r}" for unit in units if not any(unit in t for t in labels)]
    legends = [*fig.legends, *(ax.get_legend() for ax in panels if ax.get_legend() is not None)]
    if any(ax.images for ax in panels) and not any(im.colorbar is not None for ax in panels for im in ax.images):
        problems.append("images without a colourbar")
    if any((ax.lines or ax.collections) and not ax.images for ax in panels) and not legends:
        problems.append("curves without a legend")
    boxes = [legend.get_window_extent(renderer) for legend in legends]
    titles = [t for t in (fig._suptitle, *(ax.title for ax in panels)) if t is not None and t.get_text()]
    problems += [f"a legend covers the title {t.get_text()!r}" for t in titles
                 if any(box.overlaps(t.get_window_extent(renderer)) for box in boxes)]
    for i, ax in enumerate(panels):
        for x, y in _plotted_points(ax):
            if any(box.contains(x, y) for box in boxes):
                problems.append(f"a legend covers a point of panel {i} at ({x:.0f}, {y:.0f}) px")
                break
    return problems


def _plotted_points(ax) -> np.ndarray:
    """Display coordinates [P, 2] of the data points an axes draws (lines, scatters, error bars)."""
    points = [line.get_transform().transform(line.get_xydata()) for line in ax.lines]
    for coll in ax.collections:
        if isinstance(coll, PathCollection):  # a scatter: its points are its offsets
            points.append(coll.get_offset_transform().transform(np.asarray(coll.get_offsets())))
        elif isinstance(coll, LineCollection):  # error bars
            points += [coll.get_transform().transform(segment) for segment in coll.get_segments() if len(segment)]
    points = np.concatenate(points) if points else np.empty((0, 2))
    return points[np.isfinite(points).all(axis=1)]
