"""Hydra structured-config schema: one dataclass per config group, validated at start.

Each YAML option under ``nct/conf/<group>/`` (package data) extends its group's schema (``defaults: [<schema>]``),
so a misspelt key or a value of the wrong type fails when the config is composed, naming the
key. Range checks live in each dataclass's ``__post_init__`` and run in `validate`.
"""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field, fields, is_dataclass
from importlib import resources
from typing import Any

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from nct.acquisition.geometry import FanGeometry
from nct.acquisition.scan import FRAMES_PER_ROTATION, SIZE
from nct.acquisition.scanner import ImageGrid, Scanner
from nct.acquisition.times import TIMES_UNITS
from nct.errors import InputError, require
from nct.fields.conf import ModelConf
from nct.fit.conf import (
    LOGGERS,
    HeldoutConf,
    LossConf,
    OptimConf,
    RenderConf,
    TrainerConf,
)
from nct.init.conf import BackgroundConf, InitConf
from nct.physics.conf import FBPConf
from nct.scenes.phantoms import (
    CircleConf,
    ComposedConf,
    HeartConf,
    LettersConf,
    StaticConf,
)
from nct.select.conf import SelectionConf


def check_n_objects(value: Any) -> None:
    """``data.n_objects`` is "auto" or a whole number >= 1 (an override gives an int, a YAML "auto" a str)."""
    if value != "auto" and not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
        raise ValueError(f"data.n_objects must be auto or a whole number >= 1, got {value!r}")


def chosen_objects(value: Any) -> int | None:
    """The K a user set (``data.n_objects``), None where it is left to the data ("auto")."""
    return None if value == "auto" else int(value)


@dataclass
class SimulateConf:
    """Simulated acquisition of ``phantom``; ``noise_i0``: incident photons per ray (None: noiseless);
    ``n_objects``: K, the objects of distinct intensity to fit ("auto": chosen from the data, never read off
    the phantom; over a background, K counts the moving parts)."""

    name: str = "simulate"
    noise_i0: float | None = None
    n_objects: Any = "auto"

    def __post_init__(self) -> None:
        if self.noise_i0 is not None and not self.noise_i0 > 0:
            raise ValueError(f"data.noise_i0 must be > 0 (or null for no noise), got {self.noise_i0}")
        check_n_objects(self.n_objects)


@dataclass
class FileConf:
    """A sinogram file in the documented ``.npz`` format, or a TIFF stack whose other keys are in the
    ``sidecar`` ``.npz`` (null: the TIFF's path ending ``.npz``); ``n_objects``: K, the objects of distinct
    intensity to fit ("auto": chosen from the data; over a background, K counts the moving parts).
    ``extent``: side of the reconstructed field of view in the file's length unit when the file
    has no truth (null: the diameter every view covers); with a truth, its grid.
    ``i0``: incident counts per ray behind the values' Poisson noise, for ``loss.data_term=poisson``
    (null: the file's own ``i0``, from its key or its flat field, else estimated from the data).
    ``times_unit``: the unit of the file's times, s or ms (null: seconds, and a gantry turn slower than a
    minute is warned of, as times in ms read as s look: `nct.acquisition.times`)."""

    name: str = "file"
    path: str = MISSING
    sidecar: str | None = None
    n_objects: Any = "auto"
    extent: float | None = None
    i0: float | None = None
    times_unit: str | None = None

    def __post_init__(self) -> None:
        if self.times_unit is not None and self.times_unit not in TIMES_UNITS:
            raise ValueError(f"data.times_unit must be one of {', '.join(TIMES_UNITS)} (or null: seconds, checked), "
                             f"got '{self.times_unit}'")
        check_n_objects(self.n_objects)
        if self.extent is not None and not self.extent > 0:
            raise ValueError(f"data.extent must be > 0 (or null for the detector's width), got {self.extent}")
        if self.i0 is not None and not (self.i0 > 0 and math.isfinite(self.i0)):
            raise ValueError(f"data.i0 must be a finite number > 0 (or null: the file's, else estimated), got {self.i0}")


@dataclass
class ScannerConf:
    """Parallel-beam acquisition; ``bin_spacing`` null means image.extent / n_bins; ``detector_offset``
    shifts the detector along itself (``geometry.py``)."""

    name: str = "parallel"
    views_per_rotation: int = 720
    rotations: float = 1.0
    rotation_time: float = 0.25
    start_deg: float = 0.0
    n_bins: int = 128
    bin_spacing: float | None = None
    detector_offset: float = 0.0

    def build(self, extent: float) -> Scanner:
        """The scanner of a field of view ``extent`` a side (``ValueError`` naming the key of a bad value)."""
        spacing = extent / self.n_bins if self.bin_spacing is None else self.bin_spacing
        return Scanner(self.views_per_rotation, self.rotations, self.rotation_time, math.radians(self.start_deg),
                       self.n_bins, spacing, detector_offset=self.detector_offset)


@dataclass
class FanScannerConf(ScannerConf):
    """Fan-beam acquisition (``geometry.FanGeometry``): the source ``source_distance`` from the axis, the
    detector (``detector_shape`` flat or curved) ``detector_distance`` beyond it; ``bin_spacing`` null
    means the n_bins bins just span the fan through the field of view's inscribed disc."""

    name: str = "fan"
    source_distance: float = 2.0
    detector_distance: float = 2.0
    detector_shape: str = "flat"

    def build(self, extent: float) -> Scanner:
        half_diagonal = extent / math.sqrt(2)
        require(self.source_distance > half_diagonal, "scanner.source_distance",
                f"> image.extent / sqrt(2) = {half_diagonal:.4g} (the source outside the image)", self.source_distance)
        spacing = self.bin_spacing
        if spacing is None:
            try:
                spacing = FanGeometry.covering(extent / 2, self.n_bins, self.source_distance, self.detector_distance,
                                               self.detector_shape).bin_spacing
            except ValueError as err:
                raise ValueError(f"scanner.{err}") from None
        return Scanner(self.views_per_rotation, self.rotations, self.rotation_time, math.radians(self.start_deg),
                       self.n_bins, spacing, self.source_distance, self.detector_distance, self.detector_shape,
                       self.detector_offset)


@dataclass
class ImageConf:
    """Reconstruction grid (``size`` pixels a side over ``extent``) and output frames per rotation."""

    size: int = SIZE
    extent: float = 1.0
    frames_per_rotation: int = FRAMES_PER_ROTATION

    def __post_init__(self) -> None:
        ImageGrid(self.size, self.extent)
        if self.frames_per_rotation < 1:
            raise ValueError(f"image.frames_per_rotation must be >= 1, got {self.frames_per_rotation}")

    def build(self) -> ImageGrid:
        return ImageGrid(self.size, self.extent)


@dataclass
class LoggerConf:
    """Training logger: tensorboard, csv or none."""

    name: str = "tensorboard"

    def __post_init__(self) -> None:
        if self.name not in LOGGERS:
            raise ValueError(f"logger.name must be one of {', '.join(LOGGERS)}, got '{self.name}'")


@dataclass
class ExportConf:
    """What a run writes besides metrics: TIFF stacks, PNG strip, GIF movie (``fps`` frames/s)."""

    tiff: bool = True
    png: bool = True
    gif: bool = True
    fps: float = 8.0
    strip_frames: int = 8

    def __post_init__(self) -> None:
        if not self.fps > 0:
            raise ValueError(f"export.fps must be > 0, got {self.fps}")
        if self.strip_frames < 1:
            raise ValueError(f"export.strip_frames must be >= 1, got {self.strip_frames}")


@dataclass
class SuspectConf:
    """When ``nct.run.suspect`` warns that a fit is poor, from the held-out views' misfits beyond
    the noise's (config group ``suspect``; the measured separation is in conf/suspect/default.yaml).
    ``fbp_ratio``: the fit's misfit above this × FBP's; ``excess``: the fit's misfit above this
    share of the views' mean |value|; ``offset_bins``: the detector offset the views' first moments
    call for (`nct.run.consistency`) above this many bins, when their centroid moves less than
    ``offset_motion_bins`` (RMS, bins) about a still object's; ``fan_radii``, ``fan_sigmas``: a
    parallel-beam file whose view totals swing like a fan beam's with the source to detector within
    this many field radii, the swing more than this many standard errors clear of none."""

    fbp_ratio: float = 1.0
    excess: float = 0.1
    offset_bins: float = 1.0
    offset_motion_bins: float = 0.5
    fan_radii: float = 7.0
    fan_sigmas: float = 5.0

    def __post_init__(self) -> None:
        require(self.fbp_ratio > 0, "suspect.fbp_ratio", "> 0", self.fbp_ratio)
        require(self.excess > 0, "suspect.excess", "> 0", self.excess)
        require(self.offset_bins > 0, "suspect.offset_bins", "> 0", self.offset_bins)
        require(self.offset_motion_bins > 0, "suspect.offset_motion_bins", "> 0", self.offset_motion_bins)
        require(self.fan_radii > 1, "suspect.fan_radii", "> 1", self.fan_radii)
        require(self.fan_sigmas > 0, "suspect.fan_sigmas", "> 0", self.fan_sigmas)


@dataclass
class NCTConf:
    """The whole run. ``seed`` fixes every random source (0 is a seed like any other).

    ``threads``: torch's intra-op threads (null: torch's default, one per core); 1 is much faster
    when several jobs share the cores.
    """

    data: Any = MISSING
    phantom: Any = MISSING
    scanner: ScannerConf = field(default_factory=ScannerConf)
    image: ImageConf = field(default_factory=ImageConf)
    fbp: FBPConf = field(default_factory=FBPConf)
    model: ModelConf = field(default_factory=ModelConf)
    motion: SelectionConf = field(default_factory=SelectionConf)
    background: BackgroundConf = field(default_factory=BackgroundConf)
    loss: LossConf = field(default_factory=LossConf)
    optim: OptimConf = field(default_factory=OptimConf)
    render: RenderConf = field(default_factory=RenderConf)
    init: InitConf = field(default_factory=InitConf)
    heldout: HeldoutConf = field(default_factory=HeldoutConf)
    trainer: TrainerConf = field(default_factory=TrainerConf)
    logger: LoggerConf = field(default_factory=LoggerConf)
    export: ExportConf = field(default_factory=ExportConf)
    suspect: SuspectConf = field(default_factory=SuspectConf)
    seed: int = 0
    method: str = "nct"
    resume: bool = False
    threads: int | None = None

    def __post_init__(self) -> None:
        self.scanner.build(self.image.extent)
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"threads must be >= 1 (or null for torch's default), got {self.threads}")
        if self.method not in ("nct", "fbp"):
            raise ValueError(f"method must be 'nct' (FBP and NCT) or 'fbp' (FBP only), got '{self.method}'")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")
        if len(self.motion.rungs) > 1 and self.heldout.every < 2:
            raise ValueError("motion=auto scores each rung on held-out views: heldout.every must be "
                             f">= 2, got {self.heldout.every}")


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
    with the jobs beside this one (a sweep's)."""
    total = physical_memory()
    per_pixel = (RASTER_BYTES * isinstance(conf.data, SimulateConf) + FRAME_BYTES * run.n_frames
                 + FIT_BYTES * conf.optim.batch_views * (conf.method == "nct"))
    image, sinogram = run.size**2 * per_pixel, VIEW_BYTES * run.n_views * run.n_bins
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


CONFIG_MODULE = "nct.conf"  # the package holding the Hydra configs (pkg://nct.conf)
SCHEMAS: dict[str, dict[str, type]] = {
    "data": {"simulate": SimulateConf, "file": FileConf},
    "phantom": {"circle": CircleConf, "heart": HeartConf, "letters": LettersConf,
                "static": StaticConf, "composed": ComposedConf},
    "scanner": {"parallel": ScannerConf, "fan": FanScannerConf},
    "image": {"default": ImageConf},
    "fbp": {"default": FBPConf},
    "model": {"default": ModelConf},
    "motion": {"default": SelectionConf},
    "background": {"default": BackgroundConf},
    "loss": {"default": LossConf},
    "optim": {"default": OptimConf},
    "render": {"default": RenderConf},
    "init": {"default": InitConf},
    "heldout": {"default": HeldoutConf},
    "trainer": {"default": TrainerConf},
    "logger": {"default": LoggerConf},
    "suspect": {"default": SuspectConf},
}


def register_configs() -> None:
    """Store the schemas: ``nct_schema`` for the primary config, ``schema_<group>_<name>`` per option.

    An option extends its schema with ``defaults: [/schema_<group>_<name>@_here_]``. The schemas
    are stored outside any config group, so that ``nct --help`` lists only the groups users pick.
    """
    cs = ConfigStore.instance()
    cs.store(name="nct_schema", node=NCTConf)
    for group, options in SCHEMAS.items():
        for name, node in options.items():
            cs.store(name=f"schema_{group}_{name}", node=node)


def validate(cfg: DictConfig) -> NCTConf:
    """Build the typed config, running every range check, and for a simulation the memory check
    (`check_memory`); raise `InputError` naming the key.

    A key no schema declares is refused too, also one added with ``+`` (Hydra lets those through).
    """
    unknown = next(undeclared_keys(cfg), None)
    if unknown is not None:
        raise InputError(unknown_key(*unknown))
    try:
        conf = OmegaConf.to_object(cfg)
    except OmegaConfBaseException as err:
        raise InputError(describe(err)) from None
    except ValueError as err:
        raise InputError(str(err)) from None
    if not isinstance(conf, NCTConf):
        raise InputError("the composed config is not an nct config (primary config must extend nct_schema)")
    if isinstance(conf.data, SimulateConf):
        scanner = conf.scanner.build(conf.image.extent)
        n_frames = len(scanner.frame_times(conf.image.frames_per_rotation))
        check_memory(conf, RunSize(conf.image.size, n_frames, scanner.n_views, conf.scanner.n_bins),
                     f"image.size={conf.image.size}", f"scanner.views_per_rotation={conf.scanner.views_per_rotation}")
    return conf


def undeclared_keys(node: DictConfig, prefix: str = "") -> Iterator[tuple[str, type]]:
    """(full key, schema) of every key of ``node`` and its children that its node's schema lacks."""
    schema = OmegaConf.get_type(node)
    declared = {f.name for f in fields(schema)} if is_dataclass(schema) else None
    for key, child in node.items_ex(resolve=False):
        full = f"{prefix}{key}"
        if declared is not None and key not in declared:
            yield full, schema
        elif isinstance(child, DictConfig):
            yield from undeclared_keys(child, full + ".")
        elif isinstance(child, ListConfig):
            for i, item in enumerate(child):
                if isinstance(item, DictConfig):
                    yield from undeclared_keys(item, f"{full}[{i}].")


def unknown_key(full_key: str, schema: type) -> str:
    """One line for a key that ``schema`` (a dataclass) does not declare, with a did-you-mean: the option
    of its group that has the key (``data.path`` -> ``data=file``), else the nearest of its keys and, at
    the top level, of the config groups (``expriment`` -> the group ``experiment``, not the key ``export``)."""
    parent, _, key = full_key.rpartition(".")
    known = [f.name for f in fields(schema)]
    where = f"{parent} ({schema.__name__})" if parent else "the config"
    owners = [name for name, node in SCHEMAS.get(parent, {}).items() if key in {f.name for f in fields(node)}]
    groups = {} if parent else {group: options for group, options in config_groups().items() if group not in known}
    close = difflib.get_close_matches(key, known + list(groups), n=1)
    if owners:
        hint = f"it is a setting of {parent}={owners[0]}: did you mean {parent}={owners[0]}?"
    elif close and close[0] in groups:
        hint = f"did you mean the config group {close[0]} ({close[0]}=<option>: {', '.join(groups[close[0]])})?"
    else:
        hint = f"did you mean {parent + '.' if parent else ''}{close[0]}?" if close else f"its keys: {', '.join(known)}"
    return f"unknown key {full_key}: not a setting of {where}; {hint}"


def config_groups() -> dict[str, list[str]]:
    """The config groups a user picks an option of (``group=option``, as ``nct --help`` lists them) and
    their options: the package's config folders, Hydra's own aside."""
    root = resources.files(CONFIG_MODULE)
    return {folder.name: sorted(f.name.removesuffix(".yaml") for f in folder.iterdir() if f.name.endswith(".yaml"))
            for folder in sorted(root.iterdir(), key=lambda f: f.name)
            if folder.is_dir() and folder.name != "hydra" and any(f.name.endswith(".yaml") for f in folder.iterdir())}


def describe(err: OmegaConfBaseException) -> str:
    """An OmegaConf error in one line, with the full key when its message lacks it."""
    return str(err).splitlines()[0] + _key_suffix(err)


def _key_suffix(err: OmegaConfBaseException) -> str:
    key = getattr(err, "full_key", None)
    return f" (key: {key})" if key and f"{key} " not in str(err).splitlines()[0] + " " else ""
