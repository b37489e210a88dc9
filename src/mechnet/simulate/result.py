"""Result: time grid, every dotted name, statistics, and the failure if there was one."""
from __future__ import annotations

import difflib
import functools
import types
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..core.arguments import name_list, output_file
from ..core.errors import UnknownNameError


def unknown_name(name: str, known, what: str = "variable") -> UnknownNameError:
    close = difflib.get_close_matches(name, list(known), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return UnknownNameError(f"{what} {name!r} does not exist in this model{hint}")


@functools.lru_cache(maxsize=8)
def _columns(names: tuple):
    """Name -> column, shared (read-only) by the results of the last few compiled models."""
    return types.MappingProxyType({n: k for k, n in enumerate(names)})


@dataclass
class Result:
    """Simulation output. `res[name]` is a numpy array on the grid `res.t` for every dotted name.

    `res.values` holds every name (a column each). It is computed when first needed: a name in
    `known` (the states and algebraics of a run with one selection) is read without it.
    """

    t: np.ndarray
    observed: object                    # (len(t), len(names)) array, or the function computing it
    names: tuple
    units: dict
    stats: dict
    x: np.ndarray                       # states on the grid (unscaled)
    z: np.ndarray
    state_names: tuple
    events: list = field(default_factory=list)
    failure: Optional[Exception] = None
    initial: dict = field(default_factory=dict)     # how the start point was found
    known: dict = field(default_factory=dict, repr=False)   # name -> values known without `observed`

    def __post_init__(self):
        self._column = _columns(tuple(self.names))
        self._values = None if callable(self.observed) else np.asarray(self.observed)

    @property
    def values(self) -> np.ndarray:
        """Every name's values, (len(t), len(names))."""
        if self._values is None:
            self._values = self.observed()
            self.observed = self._values          # lets the run (integrators, raw arrays) go
        return self._values

    def __getstate__(self):
        """Pickled with every name computed (the function computing them is the run's)."""
        state = dict(self.__dict__)
        state["_values"] = state["observed"] = self.values
        del state["_column"]                      # shared: rebuilt on loading
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._column = _columns(tuple(self.names))

    @property
    def success(self) -> bool:
        return self.failure is None

    def __getitem__(self, name: str) -> np.ndarray:
        if not isinstance(name, str):
            raise UnknownNameError(f"results are read by dotted name, such as res[{self.names[0]!r}] "
                                   f"(got {name!r}); res.t holds the times" if self.names else
                                   f"results are read by dotted name (got {name!r})")
        if name not in self._column:
            raise unknown_name(name, self.names)
        if self._values is None and name in self.known:
            return self.known[name]
        return self.values[:, self._column[name]]

    def __contains__(self, name) -> bool:
        return name in self._column

    @property
    def final_time(self) -> float:
        return float(self.t[-1])

    @property
    def final_state(self) -> dict:
        """State values at the last time point (of the selection running there).

        To continue a run use `cm.simulate(t_end, continue_from=res)`: it fixes
        these and guesses everything else from `final_values`.
        """
        return {n: float(self.x[-1, k]) for k, n in enumerate(self.state_names)}

    @property
    def final_values(self) -> dict:
        """Every dotted name's value at the last time point."""
        return {n: float(v) for n, v in zip(self.names, self.values[-1])}

    def to_csv(self, path, names=None) -> None:
        """Write time and the named variables (default: every name) as CSV with a units row comment."""
        names = name_list(names, "to_csv(names=...)") if names else list(self.names)
        for n in names:
            if n not in self._column:
                raise unknown_name(n, self.names)
        path = output_file(path, "to_csv(path)")
        data = np.column_stack([self.t] + [self[n] for n in names])
        header = ",".join(["time"] + names)
        units = "# units: " + ",".join(["s"] + [self.units.get(n, "1") for n in names])
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(units + "\n" + header + "\n")
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")

    def plot(self, names=None, ax=None):
        """Plot named variables against time (default: the states); returns the matplotlib Figure."""
        import matplotlib.pyplot as plt

        names = name_list(names, "plot(names)") if names else list(self.state_names[:6])
        for n in names:
            if n not in self._column:
                raise unknown_name(n, self.names)
        if ax is None:
            fig, ax = plt.subplots(figsize=(8, 4.5))
        else:
            fig = ax.figure
        for n in names:
            ax.plot(self.t, self[n], label=f"{n} [{self.units.get(n, '1')}]")
        ax.set_xlabel("time [s]")
        units = {self.units.get(n, "1") for n in names}
        ax.set_ylabel(units.pop() if len(units) == 1 else "value")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
        if self.failure is not None:
            ax.set_title(f"integration failed at t = {self.t[-1]:.6g} s", color="red")
        fig.tight_layout()
        return fig

    def __repr__(self):
        status = "ok" if self.success else f"FAILED: {self.failure}"
        return f"<Result {len(self.t)} points, t = {self.t[0]:g}..{self.t[-1]:g} s, {status}>"
