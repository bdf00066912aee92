"""The ``nct`` command: a Hydra application around `nct.pipeline.run`."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from nct.config import register_configs

CONFIG_MODULE = "nct.conf"

# Cached: Hydra copies the resolver cache into every job, so all jobs of a sweep share one folder.
OmegaConf.register_new_resolver("nct_pid", lambda: str(os.getpid()), replace=True, use_cache=True)
register_configs()


@hydra.main(version_base="1.3", config_path=f"pkg://{CONFIG_MODULE}", config_name="config")
def app(cfg: DictConfig) -> float | None:
    """Run one reconstruction into Hydra's output folder; return the truth-free held-out loss."""
    from nct.errors import InputError
    from nct.pipeline import run_job

    hydra_cfg = HydraConfig.get()
    out_dir = Path(hydra_cfg.runtime.output_dir)
    try:
        return run_job(cfg, out_dir, list(hydra_cfg.overrides.task))
    except InputError as err:
        print(f"nct: error: {err}", file=sys.stderr)
        if hydra_cfg.mode.name == "RUN":
            sys.exit(2)
        raise


def main() -> None:
    """Console entry point (``nct``)."""
    app()


if __name__ == "__main__":
    main()
