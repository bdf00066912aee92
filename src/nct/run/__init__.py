"""One run from config to files: pipeline, metrics, export, tracking, outcome."""
