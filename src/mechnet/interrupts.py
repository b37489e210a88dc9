"""Ctrl-C during a run: stop at once, with what was computed.

CasADi checks Python's signals inside its function evaluations. A SIGINT arriving there runs the
handler, whose KeyboardInterrupt CasADi swallows: the evaluation fails, SUNDIALS reports
CV_RHSFUNC_FAIL and IPOPT Invalid_Number_Detected. Left alone, the run loop took that for a solver
failure and retried it (Adams -> BDF, a piece in halves) and the run finished as if nothing had happened.

So while a run is active in the main thread, `watching()` chains a handler in front of the one installed:
it lets that handler act (Python's default raises KeyboardInterrupt) and notes that an interrupt arrived
when it raised. The run loops ask `interrupted()` after every solver call and failure and, when it did,
stop retrying and raise `Interrupted` (a KeyboardInterrupt: `except KeyboardInterrupt` catches it)
carrying what was computed. The previous handler is back in place when the outermost run ends, so
Ctrl-C outside a run is Python's own. Runs in other threads (where signal handlers cannot be set, and
where signals never reach CasADi) are not watched.
"""
from __future__ import annotations

import functools
import signal
import threading
import time
from contextlib import contextmanager


class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (SIGINT). `result` holds what was computed: for `cm.simulate` and a
    prepared run the partial Result (its `failure.reason == "interrupted"`), for `mn.sweep` a Sweep of
    the finished runs, for an optimal control solve a Solution at the last iterate (`stats["status"] ==
    "interrupted"`); None when the run stopped before it had any. `signalled_at`: `time.monotonic()`
    when the signal's handler ran."""

    def __init__(self, what: str, result=None, signalled_at: float | None = None):
        super().__init__(f"{what} interrupted (Ctrl-C); what was computed is in the exception's .result")
        self.what, self.result = what, result
        self.signalled_at = _signalled_at if signalled_at is None else signalled_at


_depth = 0                      # runs active in the main thread (nested: a sweep's, a prepared run's)
_signalled_at = None            # monotonic time of the interrupt during the active runs, or None
_previous = None                # the handler that was installed before the outermost run (kept after it)


def _handler(signum, frame):
    """The previous handler first: when it raises (an interrupt), note it and let it raise on."""
    global _signalled_at
    try:
        (_previous or signal.default_int_handler)(signum, frame)
    except BaseException:
        if _signalled_at is None:
            _signalled_at = time.monotonic()
        raise


@contextmanager
def watching():
    """Within the block, a SIGINT in the main thread is noted (`interrupted()`). The outermost block
    installs the handler and puts the previous one back; a previous handler that is not Python code
    (ignored, or the system default, which ends the process) is left alone, as are other threads."""
    global _depth, _signalled_at, _previous
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if _depth == 0:
        previous = signal.getsignal(signal.SIGINT)
        if previous is _handler:                 # left behind by an interrupt inside a `finally` below
            previous = _previous or signal.default_int_handler
        if not callable(previous):
            yield
            return
        _previous, _signalled_at = previous, None
    _depth += 1
    try:
        if _depth == 1:
            signal.signal(signal.SIGINT, _handler)
        yield
    finally:
        _depth -= 1
        if _depth == 0 and signal.getsignal(signal.SIGINT) is _handler:   # (a handler set during the run stays)
            signal.signal(signal.SIGINT, _previous)


def interrupted() -> bool:
    """Whether a SIGINT arrived during the active runs (always False outside the main thread)."""
    return _signalled_at is not None and _depth > 0 and threading.current_thread() is threading.main_thread()


def watched(what: str):
    """A run's entry point, watched (`watching`): an exception while interrupted (a KeyboardInterrupt,
    or a failure CasADi made of one) becomes `Interrupted`, as does a return after an interrupt the run
    did not act on (carrying what it returned). An `Interrupted` from within passes unchanged."""
    def decorate(function):
        @functools.wraps(function)
        def run(*args, **kwargs):
            with watching():
                try:
                    out = function(*args, **kwargs)
                except Interrupted:
                    raise
                except BaseException as exc:
                    if isinstance(exc, KeyboardInterrupt) or interrupted():
                        raise Interrupted(what) from None
                    raise
                if interrupted():
                    raise Interrupted(what, out)
                return out
        return run
    return decorate
