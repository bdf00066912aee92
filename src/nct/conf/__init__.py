"""nct's Hydra configs, shipped inside the package (``pkg://nct.conf``) so that any install runs ``nct``."""
