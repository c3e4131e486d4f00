class RaytraceError(ValueError):
    """A problem with the user's input, reported as one line, no traceback."""


class OptionError(RaytraceError):
    """A render option out of its range or choices: on the command line, a
    bad argument (exit 2), wherever it is found."""


class RaytraceWarning(UserWarning):
    """Something in the input the renderer approximates (a file's glass or
    textured material, a missing MTL file): one line, and the render goes on."""


def warn(message):
    """Tell the user of something approximated: a RaytraceWarning, which
    Python shows once per message (the command line: one line each)."""
    import warnings
    warnings.warn(message, RaytraceWarning, stacklevel=2)
