"""The ``nct`` command: a Hydra application around `nct.pipeline.run`."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from nct.config import register_configs

CONFIG_DIR = Path(__file__).resolve().parents[2] / "conf"

# Cached: Hydra copies the resolver cache into every job, so all jobs of a sweep share one folder.
OmegaConf.register_new_resolver("nct_pid", lambda: str(os.getpid()), replace=True, use_cache=True)
register_configs()


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def app(cfg: DictConfig) -> float | None:
    """Run one reconstruction into Hydra's output folder; return the truth-free held-out loss."""
    from nct.errors import InputError, MethodError
    from nct.pipeline import run_job

    hydra_cfg = HydraConfig.get()
    out_dir = Path(hydra_cfg.runtime.output_dir)
    try:
        return run_job(cfg, out_dir, list(hydra_cfg.overrides.task))
    except (InputError, MethodError) as err:
        # Expected failures: one line; the run folder's status.json keeps the reason.
        print(f"nct: error: {err}", file=sys.stderr)
        if hydra_cfg.mode.name == "RUN":
            sys.exit(2 if isinstance(err, InputError) else 1)
        raise


def main() -> None:
    """Console entry point (``nct``)."""
    if not CONFIG_DIR.is_dir():
        sys.exit(f"nct: error: config folder {CONFIG_DIR} not found: install nct from a source checkout "
                 "(pip install -e .)")
    app()


if __name__ == "__main__":
    main()
