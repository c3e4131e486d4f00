"""Ctrl-C, remembered: the command's SIGINT handler notes that it came, so
one that Python dropped still stops the command (cli/command.py, cli/main.py)."""
import sys

_interrupted = False


def on_sigint(signum, frame):
    """Python's own handler, which also remembers that Ctrl-C came: a C
    extension importing when it lands may turn the KeyboardInterrupt into an
    ImportError ("numba._devicearray failed to import")."""
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def interrupted():
    return _interrupted


def unraisable(info):
    """A Ctrl-C that lands in a weakref callback or a __del__ cannot propagate:
    Python prints it as "Exception ignored" and goes on.  Keep quiet about it:
    raise_if_interrupted reports it at the command's next check."""
    if not issubclass(info.exc_type, KeyboardInterrupt):
        sys.__unraisablehook__(info)


def raise_if_interrupted():
    """Raise the KeyboardInterrupt of a Ctrl-C that Python dropped (see
    unraisable; code called from C that clears errors drops it silently), so
    the command still stops with 130 rather than finish as if not asked to."""
    if _interrupted:
        raise KeyboardInterrupt
