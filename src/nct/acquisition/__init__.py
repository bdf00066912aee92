"""What was measured and how: scan geometry, scanner, sinogram, files, rebinning."""
