"""Does the truth-free geometry check (`nct.run.consistency`) name a wrong geometry in a file, and stay
quiet on right ones? (issue 28, item 3: a fit absorbs a wrong geometry as motion, so its held-out
misfits miss it.)

Each experiment (conf/experiment/*.yaml, default settings, 128 px) is simulated in parallel and in fan
beam by `nct ... method=fbp` (its run writes sinogram.npz); each file is then read back as it is and
with its geometry rewritten: detector_offset moved by 1, 3 and 10 bins, bin_spacing scaled by 0.95,
1.05 and 1.10, a fan file's fan keys dropped (read as parallel beam); also the circle at 150, 200 and
300 deg/rotation and with Poisson noise (I0 1000, 100). The table gives the check's measures and
whether it warns at the default limits (conf/suspect/default.yaml).

Writes README.md (the table and the command) into benchmarks/results/geometry_check/.
Run: python benchmarks/geometry_check.py [--out DIR]   (~4 min here: 15 FBP runs of ~15 s)
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from nct.acquisition.io import load_sinogram
from nct.run.conf import SuspectConf
from nct.run.consistency import check_geometry, geometry_warnings

FAN_KEYS = ("source_distance", "detector_distance", "detector_shape")
EXPERIMENTS = {f"{e}_{s}": [f"experiment={e}", f"scanner={s}"]
               for e in ("circle", "heart", "heart_cine", "letters", "static") for s in ("parallel", "fan")}
OTHERS = {**{f"circle{d}_parallel": [f"phantom.displacement_deg={d}"] for d in (150, 200, 300)},
          **{f"circle_i{i}_parallel": [f"data.noise_i0={i}"] for i in (1000, 100)}}
EDITS = {"ok": {}, **{f"offset{b}": {"offset_bins": b} for b in (1, 3, 10)},
         **{f"spacing{round(100 * f)}": {"spacing": f} for f in (0.95, 1.05, 1.10)}}


def simulate(name: str, overrides: list[str], folder: Path) -> Path:
    """The sinogram file of an FBP-only run of ``overrides``."""
    run = folder / name
    subprocess.run([sys.executable, "-m", "nct.cli.main", *overrides, "method=fbp", "logger=none", "threads=1",
                    "export.gif=false", "export.png=false", "export.tiff=false", f"hydra.run.dir={run}"],
                   check=True, capture_output=True)
    return run / "sinogram.npz"


def rewrite(source: Path, target: Path, offset_bins: float = 0.0, spacing: float = 1.0,
            as_parallel: bool = False) -> Path:
    """``source`` with its geometry made wrong: offset moved, pitch scaled, fan keys dropped."""
    keys = dict(np.load(source))
    pitch = float(keys["bin_spacing"])
    keys["detector_offset"] = np.float64(float(keys.get("detector_offset", 0.0)) + offset_bins * pitch)
    keys["bin_spacing"] = np.float64(pitch * spacing)
    for key in FAN_KEYS if as_parallel else ():
        keys.pop(key, None)
    np.savez(target, **keys)
    return target


def row(name: str, path: Path) -> str:
    """One table row: the file's offset (bins), centroid motion (bins), fan swing and warnings."""
    sino = load_sinogram(path)
    check = check_geometry(sino)
    lines = geometry_warnings(check, sino, SuspectConf())
    warned = ", ".join("offset" if "shifted" in line else "fan read as parallel" for line in lines) or "-"
    fan = check.fan
    swing = " | " if fan is None else f"{fan.nearest:.3g} .. {fan.radii:.3g} | {fan.sigmas:.3g}"
    return f"| {name} | {check.offset.bins:.2f} | {check.offset.motion_bins:.2f} | {swing} | {warned} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/geometry_check"))
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for scan, overrides in (EXPERIMENTS | OTHERS).items():
            source = simulate(scan, overrides, folder)
            for edit, change in (EDITS if scan in EXPERIMENTS else {"ok": {}}).items():
                rows.append(row(f"{scan} {edit}", rewrite(source, folder / f"{scan}_{edit}.npz", **change)))
            if scan.endswith("_fan"):
                rows.append(row(f"{scan} read as parallel", rewrite(source, folder / f"{scan}_par.npz", as_parallel=True)))
            print(rows[-1], flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    header = [("| file | offset (bins) | motion (bins) | fan swing: source to detector, field radii (min .. max) "
               "| standard errors | warns |"), "| --- | --- | --- | --- | --- | --- |"]
    (args.out / "README.md").write_text(
        "# The geometry check on right and wrong files\n\n`python benchmarks/geometry_check.py`; limits: "
        "conf/suspect/default.yaml. Offset: what every centroid model needs (0: they disagree); motion: RMS of the "
        "first moments about a still object's; fan swing only for parallel-beam files.\n\n"
        + "\n".join(header + rows) + "\n")


if __name__ == "__main__":
    main()
