"""What SUNDIALS prints during a run, kept with that run instead of reaching stderr.

SUNDIALS reports through CasADi, which writes to Python's `sys.stderr`: "The linesearch algorithm failed
with too small a step." 7-19 times in a slider-crank run that succeeds, "mxstep steps taken" from a
piece the run retries shorter on purpose. `contextlib.redirect_stderr` would swap the stream for the
whole process, mixing or dropping the messages of runs in other threads. Instead `sys.stderr` is
replaced once by a stream that hands each write to the capture of the thread that makes it (CasADi
calls back into Python from the thread running the integrator), and passes every other write through.
"""
from __future__ import annotations

import contextlib
import sys
import threading

_captures = threading.local()
_install_lock = threading.Lock()


class _ThreadStream:
    """sys.stderr for the process: a write goes to the writing thread's capture, if it has one."""

    def __init__(self, fallback):
        self.fallback = fallback

    def write(self, text):
        record = getattr(_captures, "record", None)
        if record is None:
            return self.fallback.write(text)
        record.append(text)
        return len(text)

    def flush(self):
        if getattr(_captures, "record", None) is None:
            self.fallback.flush()

    def __getattr__(self, name):          # encoding, isatty, fileno...: the real stream's
        return getattr(self.fallback, name)


def terminal():
    """The real stderr (a progress bar must reach the user, not a run's record); None where there is none."""
    _install()
    return sys.stderr.fallback if isinstance(sys.stderr, _ThreadStream) else sys.stderr


def _install():
    if isinstance(sys.stderr, _ThreadStream):        # installed (every run asks: no lock needed to see it)
        return
    with _install_lock:
        # no stderr at all (pythonw, a daemon): nothing to wrap, and a run's text is only what CasADi
        # writes while captured
        if sys.stderr is not None and not isinstance(sys.stderr, _ThreadStream):
            sys.stderr = _ThreadStream(sys.stderr)


@contextlib.contextmanager
def captured():
    """Within the block, this thread's writes to sys.stderr are kept in the yielded list of messages
    (one per line, blank lines dropped); nested blocks share the outer record."""
    _install()
    outer = getattr(_captures, "record", None)
    raw = outer if outer is not None else []
    _captures.record = raw
    messages: list[str] = []
    try:
        yield messages
    finally:
        _captures.record = outer
        if outer is None:
            messages.extend(line.strip() for line in "".join(raw).splitlines() if line.strip())
