"""Truth-free warnings that a fit is poor, from the views it never saw (``heldout``).

The fit's held-out misfit (``NCTResult.heldout_loss``) against FBP's and the noise's (select/misfits.py): a fit
that explains the held-out views worse than FBP, or leaves much of them unexplained, is suspect (thresholds:
``suspect``). A run whose first winner is worse than FBP has raced the next scene model already (select/race.py).
"""

from __future__ import annotations

from nct.run.conf import SuspectConf
from nct.select.misfits import HeldoutMisfits


def suspect_warnings(m: HeldoutMisfits, conf: SuspectConf, from_file: bool) -> list[str]:
    """One line per reason to doubt the fit: beyond the noise's misfit, it misfits the held-out
    views more than ``conf.fbp_ratio`` × FBP does, or more than ``conf.excess`` of their mean.
    ``from_file``: the data came from a file, whose geometry may be wrong (a simulation's is not)."""
    nct = m.nct - m.noise
    causes = ("a wrong geometry in the file (fan or parallel, bin_spacing, detector_offset), too few steps or objects?"
              if from_file else "too few steps or objects?")
    out = []
    if m.above_fbp(conf.fbp_ratio):
        out.append(f"suspect fit: its held-out misfit {m.nct:.3g} is above FBP's {m.fbp:.3g} "
                   f"(beyond the noise's {m.noise:.3g}; limit suspect.fbp_ratio={conf.fbp_ratio:g} x FBP's): "
                   "too few steps, or too few objects (data.n_objects)?")
    if nct > conf.excess:
        out.append(f"suspect fit: its held-out misfit {m.nct:.3g} leaves {nct:.1%} of the views' mean unexplained "
                   f"beyond the noise (limit suspect.excess={conf.excess:g}): {causes}")
    return out
