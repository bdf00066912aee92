"""Hydra structured-config schema of the whole run: `NCTConf` (one field per config group, each group's
dataclass beside the code that reads it), the options of every group (`SCHEMAS`) and their storing
(`register_configs`). Each YAML option under ``nct/conf/<group>/`` (package data) extends its group's
schema (``defaults: [<schema>]``), so a misspelt key or a value of the wrong type fails when the config
is composed, naming the key; ``config.validate`` runs the range checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hydra.core.config_store import ConfigStore
from omegaconf import MISSING

from nct.fields.conf import ModelConf
from nct.fit.conf import CallbacksConf, HeldoutConf, LossConf, OptimConf, RenderConf, TrainerArgs
from nct.init.conf import BackgroundConf, InitConf
from nct.physics.conf import FBPConf
from nct.run.conf import (
    ExportConf,
    FanScannerConf,
    FileConf,
    ImageConf,
    LoggerConf,
    ScannerConf,
    SimulateConf,
    SuspectConf,
)
from nct.scenes.phantoms import CircleConf, ComposedConf, HeartConf, LettersConf, StaticConf
from nct.select.conf import SelectionConf


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
    trainer: TrainerArgs = field(default_factory=TrainerArgs)
    callbacks: CallbacksConf = field(default_factory=CallbacksConf)
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
            raise ValueError(f"motion.rungs {self.motion.rungs} are compared on held-out views: heldout.every must "
                             f"be >= 2 (or one rung, e.g. motion=free), got {self.heldout.every}")


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
    "trainer": {"default": TrainerArgs},
    "callbacks": {"default": CallbacksConf},
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
