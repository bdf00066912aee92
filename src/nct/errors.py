"""Errors the command line reports in one line, without a traceback."""


class InputError(ValueError):
    """Bad user input (a config value or a data file): the message names the key and what was expected."""


class DivergenceError(RuntimeError):
    """A fit that diverged (NaN or exploding loss): the run is stopped and recorded as diverged."""
