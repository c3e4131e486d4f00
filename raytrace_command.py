"""The `raytrace` console script's entry point ([project.scripts]).  It sits
outside the raytrace package because importing raytrace.cli.command runs
the package's __init__ first, where a Ctrl-C in the command's first
milliseconds was a KeyboardInterrupt traceback: here the whole import is
inside the try, so Ctrl-C at any moment after Python's own start-up is exit
130 and one line.  raytrace.cli.command.main does the rest."""
import os
import sys


def main():
    try:
        from raytrace.cli.command import main as command_main
        return command_main()
    except KeyboardInterrupt:
        # Only before command_main installed its handler; the same line as it.
        sys.stderr.write("interrupted: no image written\n")
        sys.stderr.flush()
        os._exit(130)         # sys.exit can turn into -2 (see cli/command.py)
