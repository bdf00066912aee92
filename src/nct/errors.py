"""Errors the command line reports in one line, without a traceback."""


class InputError(ValueError):
    """Bad user input (a config value or a data file): the message names the key and what was expected."""


class DivergenceError(RuntimeError):
    """A fit that diverged (NaN or exploding loss): the run is stopped and recorded as diverged."""


def require(ok: bool, key: str, expected: str, got: object) -> None:
    """Raise ValueError naming the config ``key`` and what was ``expected`` unless ``ok``."""
    if not ok:
        raise ValueError(f"{key} must be {expected}, got {got!r}")
