"""The command-line entry points (nct, nct-export, nct-report)."""
