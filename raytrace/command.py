"""The `raytrace` command's entry point.  It imports nothing heavy before it
can report Ctrl-C as an interruption: a SIGINT while click and the rest load
is exit 130 and one line, like one during the render."""
import sys


def main():
    try:
        from .cli import entry
    except KeyboardInterrupt:
        sys.stderr.write("interrupted: no image written\n")
        sys.exit(130)
    entry()
