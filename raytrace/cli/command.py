"""The `raytrace` command's main (entered through raytrace_command, outside
the package, which also covers the package's own import).  It imports
nothing heavy before it can report Ctrl-C as an interruption: a SIGINT while
click and the rest load is exit 130 and one line, like one during the render."""
import os
import sys

from raytrace.renderer import interrupt


def _exit_interrupted(message=None):
    """Exit 130 after Ctrl-C, through os._exit.  CPython 3.11 kills the process
    with SIGINT at exit, whatever sys.exit said, when the KeyboardInterrupt was
    raised inside exec()'d code (namedtuple and dataclass creation while a
    module loads): the caller would see -2 instead of 130."""
    if message:
        sys.stderr.write(f"{interrupt.label()}: {message}\n")
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(interrupt.exit_code())


def main():
    interrupt.install()
    try:
        from raytrace.cli.main import entry
        entry()
    except SystemExit as exc:
        if exc.code in interrupt.exit_codes():
            _exit_interrupted()                     # the message is written
        raise
    except KeyboardInterrupt:
        _exit_interrupted("no image written")
    except Exception:
        if interrupt.interrupted():
            _exit_interrupted("no image written")
        raise
