"""The rows a run records, kept in the blocks the integrator returns them in.

Each row is a time, the states and algebraic variables there, the selection that integrated them and
the modes. An integrator call returns its rows as one matrix; split into one array per row and joined
again for the result, 500 rows cost 0.3 ms, as much as the whole integration of a small model
(docs/benchmarks.md, overhead). A block keeps the call's matrices as they are.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..numeric import mapped_in


class Row(NamedTuple):
    t: float
    x: np.ndarray
    z: np.ndarray
    dae: object
    d: np.ndarray


class Block(NamedTuple):
    t: np.ndarray          # (n,)
    x: np.ndarray          # (n, states)
    z: np.ndarray          # (n, algebraics)
    dae: object            # the selection that integrated these rows
    d: np.ndarray          # the modes, the same for every row of a block
    observed: np.ndarray | None = None   # (n, observed names) given, not computed from x and z (`_bridge`)


class Rows:
    """A run's recorded rows. The blocks own their arrays (callers hand over fresh ones)."""

    def __init__(self):
        self.blocks: list[Block] = []
        self.count = 0

    def __len__(self) -> int:
        return self.count

    def add(self, t, x, z, dae, d, observed=None):
        """Rows at the times t (n,) with the states x (n, states) and algebraics z (n, algebraics);
        `observed` (n, observed names) when the selection's formulas cannot give them there."""
        if len(t):
            self.blocks.append(Block(np.asarray(t, dtype=float), x, z, dae, d, observed))
            self.count += len(t)

    def add_row(self, t, x, z, dae, d, observed=None):
        self.add(np.array([t], dtype=float), np.array(x, dtype=float).reshape(1, -1),
                 np.array(z, dtype=float).reshape(1, -1), dae, d,
                 None if observed is None else np.array(observed, dtype=float).reshape(1, -1))

    @property
    def first_time(self) -> float:
        return float(self.blocks[0].t[0])

    @property
    def last(self) -> Row:
        b = self.blocks[-1]
        return Row(float(b.t[-1]), b.x[-1], b.z[-1], b.dae, b.d)

    @property
    def last_solved(self) -> Row | None:
        """The last row whose values come from its own x and z (not given next to a change point)."""
        b = next((b for b in reversed(self.blocks) if b.observed is None), None)
        return None if b is None else Row(float(b.t[-1]), b.x[-1], b.z[-1], b.dae, b.d)

    def replace_last(self, x, z, dae):
        """The last row holds (x, z) of selection `dae` instead (a re-selection at a recorded time)."""
        last = self.blocks[-1]
        self.drop_last()
        self.add_row(last.t[-1], x, z, dae, last.d)

    def drop_last(self):
        """Forget the last row (a state at an event instant that is on neither side of it)."""
        b = self.blocks.pop()
        self.count -= len(b.t)
        if len(b.t) > 1:
            self.add(b.t[:-1], b.x[:-1], b.z[:-1], b.dae, b.d, None if b.observed is None else b.observed[:-1])

    def keep_first(self, n: int):
        """Only the first n rows stay (a failed run's partial result ends at its last finite row)."""
        while self.count > n:
            b = self.blocks.pop()
            self.count -= len(b.t)
            keep = n - self.count
            if keep > 0:
                self.add(b.t[:keep], b.x[:keep], b.z[:keep], b.dae, b.d, None if b.observed is None else b.observed[:keep])

    def backwards(self):
        """The rows from the last to the first."""
        for b in reversed(self.blocks):
            for k in range(len(b.t) - 1, -1, -1):
                yield Row(float(b.t[k]), b.x[k], b.z[k], b.dae, b.d)

    def times(self) -> np.ndarray:
        return np.concatenate([b.t for b in self.blocks]) if self.blocks else np.zeros(0)

    def by_selection(self):
        """(dae, t, x, z, d, observed) for each stretch of rows integrated with one selection, d one row
        of modes per row; `observed` None (computed from x and z) except for a block that gives them."""
        k = 0
        while k < len(self.blocks):
            j = k
            while self.blocks[k].observed is None and j + 1 < len(self.blocks) \
                    and self.blocks[j + 1].dae is self.blocks[k].dae and self.blocks[j + 1].observed is None:
                j += 1
            part = self.blocks[k: j + 1]
            rows = sum(len(b.t) for b in part)
            d = np.repeat(np.reshape(part[0].d, (1, -1)), rows, axis=0) if all(b.d is part[0].d for b in part) \
                else np.concatenate([np.tile(np.asarray(b.d, dtype=float).reshape(1, -1), (len(b.t), 1)) for b in part])
            yield (part[0].dae, _joined([b.t for b in part]), _joined([b.x for b in part]),
                   _joined([b.z for b in part]), d, part[0].observed)
            k = j + 1


def _joined(parts):
    """Arrays joined along their first axis (one part: itself, no copy)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def observe(dae, T, X, Z, plan, p, D) -> np.ndarray:
    """The observed names at the rows (T, X, Z), each with its own modes (a row of D)."""
    n = T.size
    if n == 0:
        return np.zeros((0, len(dae.observed_names)))
    U = plan.at(T)
    observed = mapped_in(dae.info.setdefault("_observed_maps", {}), dae.observed, n)
    y, = observed(T.reshape(1, -1), X.T, Z.T, U, np.tile(p.reshape(-1, 1), n), D.reshape(n, -1).T)
    return y.T
