"""nct: time-resolved CT of moving objects with neural signed distance functions (NeuralCT)."""

__version__ = "0.1.0"
