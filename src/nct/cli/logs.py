"""A filter for Hydra's log config: the plugins' lines that only echo their settings are dropped,
while their job lists, results, warnings and errors stay (conf/hydra/hydra_logging/quiet.yaml)."""

from __future__ import annotations

import logging
from collections.abc import Sequence


class DropEcho(logging.Filter):
    """Drops records whose message starts with one of ``prefixes``."""

    def __init__(self, prefixes: Sequence[str]) -> None:
        super().__init__()
        self.prefixes = tuple(prefixes)

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(self.prefixes)
