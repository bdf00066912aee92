"""Errors the command line reports in one line, without a traceback."""


class InputError(ValueError):
    """Bad user input (a config value or a data file): the message names the key and what was expected."""
