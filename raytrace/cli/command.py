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


def _end(code):
    """Exit with ``code`` (sys.exit's argument) once the command is done:
    the exit handlers run (a second process's cache folder, Dask's
    clusters, logging), the output is flushed, and the process ends
    without Python's teardown, which frees every compiled kernel's module
    one by one: 0.35-0.46 s after a first render, 0.10-0.13 s after a
    warm one of 0.5 s (docs/benchmarks.md, "A process ends at once").
    Where a thread that is not a daemon still runs, the usual exit, which
    waits for it."""
    import atexit
    import threading
    main_thread = threading.main_thread()
    if any(not t.daemon for t in threading.enumerate() if t is not main_thread):
        sys.exit(code)
    if code is None:
        code = 0
    elif not isinstance(code, int):
        sys.stderr.write(f"{code}\n")       # as sys.exit writes a message
        code = 1
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):       # a closed pipe or stream: nothing more to say
            pass
    os._exit(code)


def main():
    interrupt.install()
    try:
        from raytrace.cli.main import entry
        entry()
    except SystemExit as exc:
        if exc.code in interrupt.exit_codes():
            _exit_interrupted()                     # the message is written
        _end(exc.code)
    except KeyboardInterrupt:
        _exit_interrupted("no image written")
    except Exception:
        if interrupt.interrupted():
            _exit_interrupted("no image written")
        raise
