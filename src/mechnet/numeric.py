"""CasADi functions called on numpy arrays, without DM conversions.

Why: turning a CasADi result into a numpy array costs about 50 ns per element,
ten times what evaluating it costs. Every observed variable at every output
time (432 × 201 for a four-bar) or a monitor batch took longer to convert than
to compute. CasADi's `Function.buffer()` reads and writes numpy memory
directly; `mapped` builds such a call for a function evaluated at many points.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .caches import built


class NumpyCall:
    """f(*arrays) -> list of arrays shaped like f's outputs (a column stays 2-D: (n, 1)).

    Thread-safe: each call takes its own buffer (5 µs; a call through DM conversions costs 80 µs for six
    arguments), so one instance cached on a compiled model serves every thread."""

    def __init__(self, f: ca.Function):
        if not all(f.sparsity_out(i).is_dense() for i in range(f.n_out())):
            raise ValueError(f"{f.name()}: outputs must be dense (densify before mapping)")
        if not all(f.sparsity_in(i).is_dense() for i in range(f.n_in())):
            raise ValueError(f"{f.name()}: inputs must be dense")
        self.f = f
        self.shape_in = [f.size_in(i) for i in range(f.n_in())]
        self.shape_out = [f.size_out(i) for i in range(f.n_out())]

    def __call__(self, *args) -> list[np.ndarray]:
        if len(args) != len(self.shape_in):
            raise ValueError(f"{self.f.name()}: {len(args)} inputs given, expected {len(self.shape_in)}")
        buffer, trigger = self.f.buffer()
        keep = []
        for i, (arg, (rows, cols)) in enumerate(zip(args, self.shape_in)):
            a = np.asarray(arg, dtype=float)
            if a.shape != (rows, cols) and not (cols == 1 and a.size == rows):     # a column: any flat shape
                raise ValueError(f"{self.f.name()}: input {i} has shape {a.shape}, expected {rows}×{cols}")
            # CasADi stores column-major: the C-order transpose has the same memory layout
            a = np.ascontiguousarray(a.reshape(rows, cols).T) if cols > 1 else np.ascontiguousarray(a.ravel())
            keep.append(a)
            buffer.set_arg(i, memoryview(a))
        outs = []
        for i, (rows, cols) in enumerate(self.shape_out):
            out = np.empty((cols, rows))
            outs.append(out)
            buffer.set_res(i, memoryview(out))
        trigger()
        return [out.T for out in outs]


def dense(f: ca.Function) -> ca.Function:
    """f with dense outputs (structural zeros stored), built from its own symbols."""
    if all(f.sparsity_out(i).is_dense() for i in range(f.n_out())):
        return f
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    return ca.Function(f.name(), args, [ca.densify(o) for o in f.call(args)], f.name_in(), f.name_out())


def mapped(f: ca.Function, n: int) -> NumpyCall:
    """f evaluated at n points in one call (inputs and outputs side by side, one column per point)."""
    return NumpyCall(dense(f).map(n))


def mapped_in(cache: dict, f: ca.Function, n: int) -> NumpyCall:
    """`mapped(f, n)`, kept in `cache` under n (a compiled model's, so across runs: building the map
    costs as much as evaluating it)."""
    return built(cache, n, lambda: mapped(f, n))
