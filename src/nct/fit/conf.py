"""Settings of the fits, one dataclass per config group, named for the code that reads it.

``trainer``: Lightning's own Trainer arguments, ``callbacks``: the settings of the stages' callbacks
(both ``trainer.run_stage``'s); ``optim``: steps and the optimiser (the stages and the passes of
``method.reconstruct``); ``render``: the occupancy and its projection (``SinogramFit``); ``heldout``: the
views held out of every fit; ``loss``: the loss weights. Plain dataclasses without torch, so that parsing
a config (``nct.run.config.validate``) stays cheap.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

from nct.errors import require

DATA_TERMS = ("l1", "poisson")  # data_term.py
LOGGERS = ("tensorboard", "csv", "none")


@dataclass
class LossConf:
    """Loss weights (config group ``loss``).

    The paper numbers its weights two ways: Algorithm 4 has lambda1 Eikonal, lambda2 TV space,
    lambda3 TV time; Sections V-VI call TV space lambda1 and TV time lambda2. Here they are named.
    eikonal: weight of mean | |grad_x g| - 1 | in SinogramFit (keeps g a distance, so a shift of
        the boundary moves the whole field with it).
    tv_space: weight of mean(|dg/dx| + |dg/dy|) (dimensionless).
    tv_time: weight of mean |dg/dt|, g in field-of-view sides and t in gantry rotations.
    init_eikonal: weight of the Eikonal term in InitFit (Algorithm 3's lambda).
    tv_background: weight of the static background's mean(|db/dx| + |db/dy|) (intensity, the
        data's peak = 1, per pixel; only with ``background=image``): keeps b from drawing the
        objects' smear or the noise.
    data_term: the sinogram term, relative to the data's mean |value| (data_term.py): ``l1``, or
        ``poisson`` (Huber within each ray's Poisson noise std, from data.i0 or estimated).
    InitFit's SDF term is the L1 misfit in pixels, inside and outside each object weighted
    equally (stages.balanced_l1).
    """

    name: str = "default"
    eikonal: float = 1.0
    tv_space: float = 0.0
    tv_time: float = 0.0
    init_eikonal: float = 0.1
    tv_background: float = 1.0
    data_term: str = "l1"

    def __post_init__(self) -> None:
        for key in ("eikonal", "tv_space", "tv_time", "init_eikonal", "tv_background"):
            require(getattr(self, key) >= 0, f"loss.{key}", ">= 0", getattr(self, key))
        require(self.data_term in DATA_TERMS, "loss.data_term", f"one of {', '.join(DATA_TERMS)}", self.data_term)


@dataclass
class TrainerArgs:
    """Lightning's Trainer arguments (config group ``trainer``: cpu | gpu), given to every stage's Trainer
    as they are: accelerator, devices; log_every_n_steps: scalars (and the divergence check's steps)."""

    name: str = "cpu"
    accelerator: str = "auto"
    devices: int = 1
    log_every_n_steps: int = 10

    def __post_init__(self) -> None:
        for key in ("devices", "log_every_n_steps"):
            require(getattr(self, key) >= 1, f"trainer.{key}", ">= 1", getattr(self, key))


@dataclass
class CallbacksConf:
    """The settings of the stages' callbacks (config group ``callbacks``, as lightning-hydra-template
    keeps them apart from the Trainer's arguments).

    progress_bar: a bar per stage (``progress.StageBar``); None shows it when stdout is a terminal
    (otherwise log lines, ``progress.StageLog``: one every progress_every_s seconds of a stage, 0: none,
    and one at its end). image_every_n_steps: frame and residual images in TensorBoard
    (``callbacks.ImageLog``). snapshot_every_n_steps: keep the field every this many steps of each
    stage and score it after the run, the points of the run's Dice-against-time curve
    (``trainer.SnapshotLog``; ``trace.csv``, ``trace.png``; 0: none).
    """

    progress_bar: bool | None = None
    progress_every_s: float = 5.0
    image_every_n_steps: int = 200
    snapshot_every_n_steps: int = 0

    def __post_init__(self) -> None:
        require(self.image_every_n_steps >= 1, "callbacks.image_every_n_steps", ">= 1", self.image_every_n_steps)
        require(self.progress_every_s >= 0, "callbacks.progress_every_s", ">= 0 (0: no progress lines)",
                self.progress_every_s)
        require(self.snapshot_every_n_steps >= 0, "callbacks.snapshot_every_n_steps", ">= 0 (0: no curve)",
                self.snapshot_every_n_steps)


@dataclass(frozen=True)
class TrainerConf:
    """How every stage's Trainer is made (``trainer.run_stage``): Lightning's ``args`` (config group
    ``trainer``) and its callbacks' settings (config group ``callbacks``), one value for the method to
    pass down."""

    args: TrainerArgs = field(default_factory=TrainerArgs)
    callbacks: CallbacksConf = field(default_factory=CallbacksConf)


@dataclass
class OptimConf:
    """Steps and optimiser of the stages (config group ``optim``).

    init_steps, fit_steps: steps of InitFit and SinogramFit in the first pass. lr: Adam's rate,
    reached after warmup_steps, then multiplied by lr_decay every lr_decay_every steps; the
    sinogram fit needs the decay: at a constant 1e-3 it wanders off even a start from the true
    SDF. refine: run the second pass (Algorithms 2-6 again) on the first pass's field,
    refine_init_steps and refine_fit_steps at refine_lr with the final band. batch_views: views
    (timepoints) per step. min_loss: stop SinogramFit once the sinogram loss is below (0: never).
    fit_intensities: SinogramFit also fits a(k), from Algorithm 1's estimate, at intensity_lr
    (Adam on log a): FBP of fast motion has no histogram peak at the object's level.
    background_lr: Adam's rate for the static background's pixels (``background=image``), in the
    data's intensity (its peak = 1) per step.
    divergence_factor: stop with DivergenceError once a loss exceeds this multiple of its start.
    coarse_size: side of the lattice on which the first pass evaluates the field, bilinearly
    upsampled to the image for rendering and the losses (an SDF is smooth, so little is lost and
    the field costs (image / coarse)^2 less per step); the refinement uses the image's own
    lattice. null, or not below the image size: the image's lattice throughout.
    fit_size: where the image is at least twice this size (pixels a side), the fit reads the views binned by
    f = size // fit_size onto a grid of size // f (`Scan.to_fit`) and the output frames are its field drawn at
    the image's size (run/reconstruct.py); null: the fit at the image's size.
    """

    init_steps: int = 300
    fit_steps: int = 1000
    refine: bool = False
    refine_init_steps: int = 50
    refine_fit_steps: int = 150
    refine_lr: float = 1e-4
    lr: float = 1e-3
    warmup_steps: int = 50
    lr_decay: float = 0.65
    lr_decay_every: int = 100
    batch_views: int = 20
    min_loss: float = 0.0
    fit_intensities: bool = True
    intensity_lr: float = 1e-2
    background_lr: float = 5e-3
    divergence_factor: float = 20.0
    coarse_size: Optional[int] = 64
    fit_size: Optional[int] = None

    def __post_init__(self) -> None:
        for key in ("coarse_size", "fit_size"):
            require(getattr(self, key) is None or getattr(self, key) >= 8, f"optim.{key}", ">= 8 or null",
                    getattr(self, key))
        for key in ("lr_decay_every", "batch_views"):
            require(getattr(self, key) >= 1, f"optim.{key}", ">= 1", getattr(self, key))
        for key in ("init_steps", "fit_steps", "refine_init_steps", "refine_fit_steps", "warmup_steps", "min_loss"):
            require(getattr(self, key) >= 0, f"optim.{key}", ">= 0", getattr(self, key))
        for key in ("lr", "refine_lr", "intensity_lr", "background_lr"):
            require(getattr(self, key) > 0, f"optim.{key}", "> 0", getattr(self, key))
        require(0 < self.lr_decay <= 1, "optim.lr_decay", "in (0, 1]", self.lr_decay)
        require(self.divergence_factor > 1, "optim.divergence_factor", "> 1", self.divergence_factor)


@dataclass
class RenderConf:
    """The rendered occupancy and its projection (config group ``render``; see render.py).

    band_px: width in pixels of the occupancy ramp; SinogramFit starts at band_start_px and
    narrows geometrically to band_px over band_anneal of its steps, so that at first a wide band
    of the boundary gets gradient. mu: the paper's occupancy slope. k_samp: supersampling.
    """

    band_px: float = 1.0
    band_start_px: float = 4.0
    band_anneal: float = 0.6
    mu: float = 50.0
    k_samp: int = 1

    def __post_init__(self) -> None:
        require(self.band_px > 0, "render.band_px", "> 0", self.band_px)
        require(self.band_start_px >= self.band_px, "render.band_start_px", ">= render.band_px", self.band_start_px)
        require(0 <= self.band_anneal <= 1, "render.band_anneal", "in [0, 1]", self.band_anneal)
        require(self.mu > 2, "render.mu", "> 2", self.mu)
        require(self.k_samp >= 1, "render.k_samp", ">= 1", self.k_samp)


@dataclass
class HeldoutConf:
    """The held-out split (config group ``heldout``): every n-th view is kept out of every fit
    (FBP included) and scores it, a truth-free number (0 or 1: none held out); with run > 1, every
    n-th run of that many consecutive views (blocks of time). check_every:
    SinogramFit scores them as Lightning validation every this many steps (``val/heldout_loss``
    in TensorBoard; 0: only after each pass)."""

    every: int = 10
    run: int = 1
    check_every: int = 100

    def __post_init__(self) -> None:
        require(self.every >= 0, "heldout.every", ">= 0", self.every)
        require(self.run >= 1, "heldout.run", ">= 1", self.run)
        require(self.check_every >= 0, "heldout.check_every", ">= 0", self.check_every)
