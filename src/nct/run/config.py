"""The composed config checked and built: `validate` turns Hydra's config into the typed `NCTConf`
(``schema.py``), refusing a key no schema declares with a did-you-mean (``suggest.py``), a value out of
range (each dataclass's ``__post_init__``) and, for a simulation, a run beyond this machine's memory
(``memory.py``), each as one `InputError` line naming the key.
"""

from __future__ import annotations

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from nct.errors import InputError
from nct.run.conf import SimulateConf
from nct.run.memory import RunSize, check_memory
from nct.run.schema import NCTConf
from nct.run.suggest import describe, undeclared_keys, unknown_key


def validate(cfg: DictConfig) -> NCTConf:
    """Build the typed config, running every range check, and for a simulation the memory check
    (`check_memory`); raise `InputError` naming the key.

    A key no schema declares is refused too, also one added with ``+`` (Hydra lets those through).
    """
    unknown = next(undeclared_keys(cfg), None)
    if unknown is not None:
        raise InputError(unknown_key(*unknown))
    try:
        conf = OmegaConf.to_object(cfg)
    except OmegaConfBaseException as err:
        raise InputError(describe(err)) from None
    except ValueError as err:
        raise InputError(str(err)) from None
    if not isinstance(conf, NCTConf):
        raise InputError("the composed config is not an nct config (primary config must extend nct_schema)")
    if isinstance(conf.data, SimulateConf):
        scanner = conf.scanner.build(conf.image.extent)
        n_frames = len(scanner.frame_times(conf.image.frames_per_rotation))
        check_memory(conf, RunSize(conf.image.size, n_frames, scanner.n_views, conf.scanner.n_bins),
                     f"image.size={conf.image.size}", f"scanner.views_per_rotation={conf.scanner.views_per_rotation}")
    return conf
