"""The optimisation stages of NeuralCT: InitFit (Algorithm 3) and SinogramFit (Algorithm 4)."""

from __future__ import annotations

from dataclasses import dataclass

from nct.fields import require


@dataclass
class LossConf:
    """Loss weights (config group ``loss``).

    The paper numbers its weights two ways: Algorithm 4 has lambda1 Eikonal, lambda2 TV space,
    lambda3 TV time; Sections V-VI call TV space lambda1 and TV time lambda2. Here they are named.
    eikonal: weight of the Eikonal term | |grad_x g| - 1 | in SinogramFit.
    tv_space: weight of the total variation of g in space; tv_time: in time.
    init_eikonal: weight of the Eikonal term in InitFit (Algorithm 3's lambda).
    """

    name: str = "default"
    eikonal: float = 0.1
    tv_space: float = 0.5
    tv_time: float = 0.5
    init_eikonal: float = 0.1

    def __post_init__(self) -> None:
        for key in ("eikonal", "tv_space", "tv_time", "init_eikonal"):
            require(getattr(self, key) >= 0, f"loss.{key}", ">= 0", getattr(self, key))


@dataclass
class TrainerConf:
    """How the stages run (config group ``trainer``).

    accelerator, devices: passed to Lightning. init_steps, fit_steps: steps of InitFit and
    SinogramFit in the first pass; refine: run the second pass (Algorithms 2-6 again).
    lr, lr_decay, lr_decay_every: Adam with step decay. batch_views: views per step.
    min_loss: stop SinogramFit once the sinogram loss is below (0: never).
    k_samp: supersampling of the render; mu: occupancy slope (paper's mu).
    progress_bar: None shows it when stdout is a terminal.
    """

    name: str = "cpu"
    accelerator: str = "auto"
    devices: int = 1
    init_steps: int = 300
    fit_steps: int = 1500
    refine: bool = True
    lr: float = 1e-3
    lr_decay: float = 0.95
    lr_decay_every: int = 200
    batch_views: int = 20
    min_loss: float = 0.0
    k_samp: int = 2
    mu: float = 50.0
    progress_bar: bool | None = None

    def __post_init__(self) -> None:
        for key in ("devices", "lr_decay_every", "batch_views", "k_samp"):
            require(getattr(self, key) >= 1, f"trainer.{key}", ">= 1", getattr(self, key))
        for key in ("init_steps", "fit_steps", "min_loss"):
            require(getattr(self, key) >= 0, f"trainer.{key}", ">= 0", getattr(self, key))
        require(self.lr > 0, "trainer.lr", "> 0", self.lr)
        require(0 < self.lr_decay <= 1, "trainer.lr_decay", "in (0, 1]", self.lr_decay)
        require(self.mu > 2, "trainer.mu", "> 2", self.mu)
