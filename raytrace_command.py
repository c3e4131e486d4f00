"""The `raytrace` console script's entry point ([project.scripts]).  It sits
outside the raytrace package because importing raytrace.cli.command runs
the package's __init__ first, where a Ctrl-C in the command's first
milliseconds was a KeyboardInterrupt traceback.  Here a Ctrl-C is noted
from this module's first statements until raytrace.cli.command is
imported, then raised and caught inside main's try, so Ctrl-C at any moment after Python's own start-up is
exit 130 and one line.  raytrace.cli.command.main does the rest."""
# _signal, not signal: always loaded, where signal's import builds its enums
# for milliseconds in which a Ctrl-C would be a traceback.
import _signal as signal

_noted = []


def _note(signum, frame):
    _noted.append(signum)


# Not if the command was started with Ctrl-C ignored (nohup, a background job).
if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
    signal.signal(signal.SIGINT, _note)


def main():
    try:
        # Imported while a Ctrl-C is only noted: raised inside the import,
        # it can land in importlib's weakref callback, where Python prints
        # "Exception ignored" and drops it, and the render went on.
        try:
            from raytrace.cli.command import main as command_main
        finally:
            if signal.getsignal(signal.SIGINT) is _note:
                signal.signal(signal.SIGINT, signal.default_int_handler)   # raised from here on
        if _noted:
            raise KeyboardInterrupt
        return command_main()
    except KeyboardInterrupt:
        # Only before command_main installed its handler; the same line as it.
        import os
        import sys
        sys.stderr.write("interrupted: no image written\n")
        sys.stderr.flush()
        os._exit(130)         # sys.exit can turn into -2 (see cli/command.py)
