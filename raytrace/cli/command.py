"""The `raytrace` command's entry point.  It imports nothing heavy before it
can report Ctrl-C as an interruption: a SIGINT while click and the rest load
is exit 130 and one line, like one during the render."""
import os
import signal
import sys

from raytrace.renderer.interrupt import interrupted, on_sigint, unraisable


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
        signal.signal(signal.SIGINT, on_sigint)     # not when started with SIGINT ignored
        sys.unraisablehook = unraisable
    try:
        from raytrace.cli.main import entry
        entry()
    except SystemExit as exc:
        if exc.code == 130:
            _exit_interrupted()                     # the message is written
        raise
    except KeyboardInterrupt:
        _exit_interrupted("no image written")
    except Exception:
        if interrupted():
            _exit_interrupted("no image written")
        raise
