"""The `raytrace` command's entry point.  It imports nothing heavy before it
can report Ctrl-C as an interruption: a SIGINT while click and the rest load
is exit 130 and one line, like one during the render."""
import os
import signal
import sys

_interrupted = False


def _on_sigint(signum, frame):
    """Python's own handler, which also remembers that Ctrl-C came: a C
    extension importing when it lands may turn the KeyboardInterrupt into an
    ImportError ("numba._devicearray failed to import")."""
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def _unraisable(info):
    """A Ctrl-C that lands in a weakref callback or a __del__ cannot propagate:
    Python prints it as "Exception ignored" and goes on.  Keep quiet about it:
    raise_if_interrupted reports it at the command's next check."""
    if not issubclass(info.exc_type, KeyboardInterrupt):
        sys.__unraisablehook__(info)


def raise_if_interrupted():
    """Raise the KeyboardInterrupt of a Ctrl-C that Python dropped (see
    _unraisable; code called from C that clears errors drops it silently), so
    the command still stops with 130 rather than finish as if not asked to."""
    if _interrupted:
        raise KeyboardInterrupt


def _exit_interrupted(message=None):
    """Exit 130 after Ctrl-C, through os._exit.  CPython 3.11 kills the process
    with SIGINT at exit, whatever sys.exit said, when the KeyboardInterrupt was
    raised inside exec()'d code (namedtuple and dataclass creation while a
    module loads): the caller would see -2 instead of 130."""
    if message:
        sys.stderr.write(f"interrupted: {message}\n")
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(130)


def main():
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _on_sigint)    # not when started with SIGINT ignored
        sys.unraisablehook = _unraisable
    try:
        from .cli import entry
        entry()
    except SystemExit as exc:
        if exc.code == 130:
            _exit_interrupted()                     # the message is written
        raise
    except KeyboardInterrupt:
        _exit_interrupted("no image written")
    except Exception:
        if _interrupted:
            _exit_interrupted("no image written")
        raise
