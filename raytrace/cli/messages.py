"""The command's messages on stderr: one line each.  A name that holds a
newline (a file name, a TOML key, -o) is escaped, not printed raw, and a
warning from any library is shown once, as one line, while it happens."""
import contextlib
import sys
import warnings

from raytrace.errors import RaytraceWarning


def escape(text):
    """``text`` with control characters (newline, carriage return, NUL, the
    Unicode line separators) written as Python escapes, so it stays one line."""
    text = str(text)
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def warning_line(message, category):
    """The one line a warning is shown as: ours as they are, another
    library's with its category, so the user knows where it came from."""
    text = escape(" ".join(str(message).split()))
    if issubclass(category, RaytraceWarning):
        return f"warning: {text}"
    return f"warning: {text} ({category.__name__})"


_shown = None   # the lines shown by the outermost warnings_once; None outside it


@contextlib.contextmanager
def warnings_once(stream=None):
    """Show each warning raised inside as one line on ``stream`` (stderr),
    the first time its line comes up.  Each is written as it is raised,
    nothing is kept but the lines already shown: recording warnings and
    showing them afterwards once re-entered the recorder and looped
    without end.  Nested uses share the outer one's lines."""
    global _shown
    if _shown is not None:
        yield
        return

    seen = set()   # its own reference: a cluster starting on another thread may warn as this ends

    def show(message, category, filename, lineno, file=None, line=None):
        text = warning_line(message, category)
        if text not in seen:
            seen.add(text)
            try:
                print(text, file=stream or sys.stderr, flush=True)
            except (OSError, ValueError):   # stderr closed: the warning is not worth a failure
                pass

    with warnings.catch_warnings():
        warnings.simplefilter("always", RaytraceWarning)   # each message once, by its text
        warnings.showwarning = show
        _shown = seen
        try:
            yield
        finally:
            _shown = None
