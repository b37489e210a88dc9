"""Events: what happened during a run, and where the integrator must restart."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Event:
    """One event of a run: its time, its kind (time, state, reselection, ...) and its cause."""

    t: float
    kind: str
    cause: str


def breakpoints(time_events: tuple, t_start: float, t_end: float) -> list[tuple[float, str]]:
    """Time events strictly inside the run, merged when they coincide."""
    out: dict[float, list[str]] = {}
    for t, cause in time_events:
        if t_start < t < t_end:
            out.setdefault(float(t), []).append(cause)
    return [(t, "; ".join(causes)) for t, causes in sorted(out.items())]


def output_grid(grid: np.ndarray, events: list) -> np.ndarray:
    """The requested output times with every event time inserted exactly once."""
    if not events:
        return grid
    return np.unique(np.concatenate([grid, [t for t, _ in events]]))


def chunk_bounds(n_points: int, chunks: int) -> list[int]:
    """Deterministic chunk boundaries (indices into the grid) for progress reporting."""
    if chunks <= 1 or n_points < 2 * chunks:
        return []
    return [round(k * (n_points - 1) / chunks) for k in range(1, chunks)]
