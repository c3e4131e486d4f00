class RaytraceError(ValueError):
    """A problem with the user's input, reported as one line, no traceback."""


class OptionError(RaytraceError):
    """A render option out of its range or choices: on the command line, a
    bad argument (exit 2), wherever it is found."""
