"""Errors the command line reports in one line, without a traceback."""


class InputError(ValueError):
    """Bad user input (a config value or a data file): the message names the key and what was expected."""


class MethodError(RuntimeError):
    """An expected failure of the method on this data: the run stops with one line and its reason."""


class DivergenceError(MethodError):
    """A fit that diverged (NaN or exploding loss): the run is stopped and recorded as diverged."""


class NoObjectError(MethodError):
    """The data hold fewer objects than asked for (e.g. an empty sinogram): says what was found."""


def require(ok: bool, key: str, expected: str, got: object) -> None:
    """Raise ValueError naming the config ``key`` and what was ``expected`` unless ``ok``."""
    if not ok:
        raise ValueError(f"{key} must be {expected}, got {got!r}")
