"""Ctrl-C, remembered: the command's SIGINT handler notes that it came, so
one that Python dropped still stops the command (cli/command.py, cli/main.py).
SIGTERM (kill, systemd, Slurm, CI) and SIGHUP (a closed terminal) end the
command the same way: one line, temporary files removed, exit 128 + the
signal's number (143, 129)."""
import signal
import sys

_interrupted = False
_signum = signal.SIGINT
# The signals that stop the command like Ctrl-C, and the word for each.
STOPPING = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated (SIGTERM)",
            signal.SIGHUP: "hung up (SIGHUP)"}


def on_sigint(signum, frame):
    """Python's own handler, which also remembers that Ctrl-C came: a C
    extension importing when it lands may turn the KeyboardInterrupt into an
    ImportError ("numba._devicearray failed to import")."""
    global _interrupted, _signum
    if not _interrupted:
        _signum = signum if signum in STOPPING else signal.SIGINT
    _interrupted = True
    raise KeyboardInterrupt


def install():
    """Stop on SIGINT, SIGTERM and SIGHUP through on_sigint, each unless the
    command was started with it ignored (nohup, a background job)."""
    for signum in STOPPING:
        default = signal.default_int_handler if signum == signal.SIGINT else signal.SIG_DFL
        if signal.getsignal(signum) is default:
            signal.signal(signum, on_sigint)
    sys.unraisablehook = unraisable
    sys.excepthook = excepthook


def label():
    """"interrupted", or what stopped the command if another signal did."""
    return STOPPING[_signum]


def exit_code():
    """128 + the stopping signal's number: 130 for Ctrl-C, 143 SIGTERM, 129 SIGHUP."""
    return 128 + int(_signum)


def exit_codes():
    return {128 + int(s) for s in STOPPING}


def interrupted():
    return _interrupted


def unraisable(info):
    """A Ctrl-C that lands in a weakref callback or a __del__ cannot propagate:
    Python prints it as "Exception ignored" and goes on.  Keep quiet about it:
    raise_if_interrupted reports it at the command's next check.  Once the
    command is stopping, so is any other such error: a callback the Ctrl-C
    cut short leaves its library's state half-changed, and the next call of
    it fails (distributed's GC timer asserts), which is not news to the user."""
    if not (issubclass(info.exc_type, KeyboardInterrupt) or _interrupted):
        sys.__unraisablehook__(info)


def excepthook(kind, value, tb):
    """sys.excepthook, quiet about a KeyboardInterrupt once Ctrl-C has come: a
    C extension whose import it cuts short prints it with PyErr_Print (NumPy's
    import_array, in Numba's extensions as `import numba` runs), then fails
    with an ImportError, which the command reports in its one line (CI saw
    the traceback above that line: test_16 at 0.25 s, under load)."""
    if not (_interrupted and issubclass(kind, KeyboardInterrupt)):
        sys.__excepthook__(kind, value, tb)


def raise_if_interrupted():
    """Raise the KeyboardInterrupt of a Ctrl-C that Python dropped (see
    unraisable; code called from C that clears errors drops it silently), so
    the command still stops with 130 rather than finish as if not asked to."""
    if _interrupted:
        raise KeyboardInterrupt
