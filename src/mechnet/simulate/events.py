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
    times = np.array([t for t, _ in events])
    # an event a rounding error away from an output time replaces it (0.3 vs 0.30000000000000004)
    scale = max(1.0, float(np.max(np.abs(grid))))
    keep = [g for g in grid if np.min(np.abs(times - g)) > 1e-12 * scale]
    return np.unique(np.concatenate([keep, times]))


def chunk_bounds(n_points: int, chunks: int) -> list[int]:
    """Deterministic chunk boundaries (indices into the grid) for progress reporting."""
    if chunks <= 1 or n_points < 2 * chunks:
        return []
    return [round(k * (n_points - 1) / chunks) for k in range(1, chunks)]
