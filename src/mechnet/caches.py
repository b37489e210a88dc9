"""What a compiled model keeps between runs, and how threads share it.

CasADi evaluates one Function from many threads at once (each call checks out its own work memory), but
two things are unsafe (measured with casadi 3.8.2, `tests/analytic/test_concurrency.py`):
- *building* expressions or Functions: SX and MX nodes are reference-counted without atomics, so two
  threads building at once corrupt the heap ("corrupted double-linked list", SIGSEGV);
- *calling one integrator*: its SUNDIALS memory is shared by every call, so a concurrent call fails
  ("tout too far back", IDA_ILL_INPUT) or returns another call's solution.
Hence one process-wide lock held while anything symbolic is built (`BUILD_LOCK`, `built`), and the
integrators kept per thread (`per_thread`), each thread's cache bounded (`BoundedCache`).
"""
from __future__ import annotations

import functools
import threading
from collections import OrderedDict

BUILD_LOCK = threading.RLock()


def built(cache: dict, key, build):
    """cache[key], built under BUILD_LOCK when missing (looked up again inside: another thread may have
    built it meanwhile). Building takes milliseconds; a lookup takes no lock."""
    try:
        return cache[key]
    except KeyError:
        pass
    with BUILD_LOCK:
        if key not in cache:
            cache[key] = build()
        return cache[key]


class BoundedCache:
    """At most `size` entries, the least recently used dropped first: a run with new output times or a
    new table shape builds a new integrator, and thousands of runs (a sweep, an optimiser's checks) must
    not keep thousands of them."""

    def __init__(self, size: int):
        self.size = size
        self._entries: OrderedDict = OrderedDict()

    def __getitem__(self, key):
        value = self._entries[key]
        self._entries.move_to_end(key)
        return value

    def __setitem__(self, key, value):
        self._entries[key] = value
        self._entries.move_to_end(key)
        while len(self._entries) > self.size:
            self._entries.popitem(last=False)

    def __contains__(self, key) -> bool:
        return key in self._entries

    def __len__(self) -> int:
        return len(self._entries)

    def keys(self):
        return list(self._entries)


class PerThread:
    """One `BoundedCache` for each thread that asks (freed with the thread); not pickled."""

    def __init__(self, size: int):
        self.size = size
        self._local = threading.local()

    def cache(self) -> BoundedCache:
        store = getattr(self._local, "cache", None)
        if store is None:
            store = self._local.cache = BoundedCache(self.size)
        return store

    def __getstate__(self):
        return {"size": self.size}

    def __setstate__(self, state):
        self.__init__(state["size"])


def builds_symbols(function):
    """Decorator for an entry point that builds expressions on every call (linearize, trim, kinematics):
    it runs under BUILD_LOCK, so threads calling it at once take turns instead of corrupting the heap."""
    @functools.wraps(function)
    def locked(*args, **kwargs):
        with BUILD_LOCK:
            return function(*args, **kwargs)
    return locked
