"""The initialisation's settings (config groups ``init`` and ``background``): plain dataclasses without
torch, so that parsing a config (``nct.run.config.validate``) stays cheap."""

from __future__ import annotations

from dataclasses import dataclass

from nct.errors import require

LEVEL_SOURCES = ("sinogram", "fbp")
INIT_ROUTES = ("auto", "gmm", "otsu")


@dataclass
class InitConf:
    """The initialisation (config group ``init``): Algorithms 1 and 2.

    frames_per_rotation: FBP frames segmented into the SDF frames InitFit fits. kappa, gmm_share:
    Algorithm 1's buffer classes and share of frames for the Gaussian mixture. route: "auto"
    (Algorithm 1, and multi-level Otsu on the foreground where it cannot separate K levels),
    "gmm" (Algorithm 1 only) or "otsu" (init/segmentation.py). levels: "sinogram" (every candidate choice
    of levels is judged by how well its masks explain the fitted views, which also give a(k):
    judge.py) or "fbp" (Algorithm 1's rule and the FBP levels). starts: with K >= 2, the judge's
    this many best segmentations each start a candidate of the tournament (initialise.find_starts;
    1: the best judged only).
    """

    frames_per_rotation: int = 60
    kappa: int = 3
    gmm_share: float = 0.02
    route: str = "auto"
    levels: str = "sinogram"
    starts: int = 2

    def __post_init__(self) -> None:
        require(self.route in INIT_ROUTES, "init.route", f"one of {INIT_ROUTES}", self.route)
        require(self.levels in LEVEL_SOURCES, "init.levels", f"one of {LEVEL_SOURCES}", self.levels)
        require(self.frames_per_rotation >= 1, "init.frames_per_rotation", ">= 1", self.frames_per_rotation)
        require(self.kappa >= 0, "init.kappa", ">= 0", self.kappa)
        require(0 < self.gmm_share <= 1, "init.gmm_share", "in (0, 1]", self.gmm_share)
        require(self.starts >= 1, "init.starts", ">= 1", self.starts)


BACKGROUNDS = ("auto", "none", "image")


@dataclass
class BackgroundConf:
    """What lies under the moving objects (config group ``background``; background.py).

    name: "none" (the paper's: K objects on an empty background), "image" (a static pixel image
    b(x) under the objects, fitted with them; the objects are then found in what moves) or "auto" (both
    offered, the held-out views choose: select/scene.py).
    moving_share: a pixel belongs to the moving region where the FBP frames' standard deviation
    over time exceeds this share of its 99.9th percentile (a share, so the rule holds at any
    contrast; the region is then widened by 2 pixels and its holes filled).
    """

    name: str = "auto"
    moving_share: float = 0.35

    def __post_init__(self) -> None:
        require(self.name in BACKGROUNDS, "background", f"one of {', '.join(BACKGROUNDS)}", self.name)
        require(0 < self.moving_share < 1, "background.moving_share", "in (0, 1)", self.moving_share)
