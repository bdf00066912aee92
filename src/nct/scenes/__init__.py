"""Truth for experiments: phantoms and their simulated sinograms."""
