"""nct: time-resolved CT of moving objects with neural signed distance functions (NeuralCT).

From Python (`nct.api`): ``nct.Scan`` (the measured data), ``nct.reconstruct`` (FBP and NeuralCT, as the
``nct`` command runs them), ``nct.load`` (a saved reconstruction), ``nct.compose`` (the command's config
with overrides), ``nct.Truth``, ``nct.Reconstruction``, ``nct.NCTConf``. They load on first use, so
``import nct`` stays light (no torch).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.1.0"

_API = ("NCTConf", "Reconstruction", "Scan", "Truth", "compose", "load", "reconstruct")
__all__ = ["__version__", *_API]

if TYPE_CHECKING:  # for type checkers and editors; at run time `__getattr__` imports them when asked for
    from nct.api import NCTConf, Reconstruction, Scan, Truth, compose, load, reconstruct  # noqa: F401


def __getattr__(name: str) -> object:
    """The public API's names, imported from `nct.api` when first asked for."""
    if name in _API:
        from nct import api

        return getattr(api, name)
    raise AttributeError(f"module 'nct' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_API})
