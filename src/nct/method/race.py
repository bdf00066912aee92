"""A race of one SinogramFit against another's held-out history, so that a fit that will not be
kept stops early (the wider temporal band, capacity.py; an initial start's runner-up, method.py).

Both fits run the same number of steps and check their held-out views at the same steps; the
challenger is compared with the rival at each check from a share ``at`` of the steps on, and
loses at the first check where its loss is above ``gain`` x the rival's there.
"""

from __future__ import annotations

HeldoutHistory = list[tuple[int, float]]  # (step, val/heldout_loss) at each held-out check of a SinogramFit


def race(challenger: HeldoutHistory, rival: HeldoutHistory, steps: int, at: float | None, gain: float) -> dict | None:
    """The race of ``challenger``'s history against ``rival``'s at each check from ``at`` x ``steps``
    until before the last step: the first check where the challenger's loss is above ``gain`` x
    the rival's (lost), else the latest (not lost so far), as {step, heldout_loss: [rival,
    challenger], gain, lost}; None with ``at`` None or before the first such check."""
    if at is None:
        return None
    theirs = dict(rival)
    due = [(step, theirs[step], loss) for step, loss in challenger if at * steps <= step < steps and step in theirs]
    if not due:
        return None
    step, against, loss = next((d for d in due if d[2] > gain * d[1]), due[-1])
    return {"step": step, "heldout_loss": [against, loss], "gain": gain, "lost": loss > gain * against}


def lost(verdict: dict | None) -> bool:
    """Whether ``race``'s verdict says the challenger lost (no verdict yet: not lost)."""
    return bool(verdict and verdict["lost"])
