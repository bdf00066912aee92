"""Settings of the physics (``fbp``: FBP's filter and window, read by ``fbp.fbp_frames``).
Plain dataclasses without torch, so that parsing a config (``nct.run.config.validate``) stays cheap."""

from __future__ import annotations

from dataclasses import dataclass

FILTERS = ("ramp", "shepp-logan", "cosine", "hamming", "hann")


@dataclass
class FBPConf:
    """FBP frames: ``filter`` one of FILTERS; ``window_deg`` 180 (shortest complete) or 360."""

    filter: str = "ramp"
    window_deg: float = 180.0

    def __post_init__(self) -> None:
        if self.filter not in FILTERS:
            raise ValueError(f"fbp.filter must be one of {', '.join(FILTERS)}, got '{self.filter}'")
        if not 0 < self.window_deg <= 360:
            raise ValueError(f"fbp.window_deg must be in (0, 360], got {self.window_deg}")
