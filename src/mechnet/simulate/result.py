"""Result: time grid, every dotted name, statistics, and the failure if there was one."""
from __future__ import annotations

import difflib
import functools
import textwrap
import types
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..core.arguments import mapping, name_list, output_file
from ..core.errors import MechnetError, UnknownNameError

# Event lines, by Event.kind: colours late in matplotlib's cycle, so rarely a curve's
EVENT_COLORS = {"time": "0.45", "state": "black", "reselection": "tab:olive", "change point": "tab:cyan",
                "method": "tab:pink", "rest": "tab:brown"}


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
    """Simulation output. `res[name]` is a numpy array on the grid `res.t` (s) for every dotted name.

    `res.units[name]` is its unit ("rad", "N*m"; "1" when dimensionless). `res.events` lists what happened,
    in time order, as `Event(t, kind, cause)`: `t` in s (also a point of `res.t`), `kind` one of "time"
    (a signal's jump or table knot), "state" (a `When` crossing), "rest" (accumulating events ended in
    the `When`'s rest mode: a ball come to rest), "reselection" (the states were re-chosen), "change
    point" (a loop stepped over a singular position) or "method" (the integrator fell back to BDF), and
    `cause` a readable text naming the signal, condition or joints. For
    analysis: `to_csv`, `to_pandas`, `plot`.

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
    title: str = ""                     # what plots are titled by default: the model's name

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

    def _checked(self, names, what: str, default) -> list:
        """Dotted names (`default` when None or empty), each one this run has."""
        names = (name_list(names, what) if names is not None else []) or list(default)
        for n in names:
            if n not in self._column:
                raise unknown_name(n, self.names)
        return names

    def _unit(self, name: str) -> str:
        """The unit of `name`; one the model does not know is dimensionless, "1"."""
        return self.units.get(name) or "1"

    def to_csv(self, path, names=None) -> None:
        """Write time and the named variables (default: every name) as CSV, one `name [unit]` per column.

        The units sit in the header row (`time [s],j1.phi [rad],...`) so that `pandas.read_csv(path)` and
        `numpy.loadtxt(path, delimiter=",", skiprows=1)` read the file as it is. Values are written with 17
        significant digits: they read back bit for bit.
        """
        names = self._checked(names, "to_csv(names=...)", self.names)
        path = output_file(path, "to_csv(path)")
        header = ",".join([_column_label("time", "s")] + [_column_label(n, self._unit(n)) for n in names])
        data = np.column_stack([self.t] + [self[n] for n in names])
        np.savetxt(path, data, delimiter=",", fmt="%.17g", header=header, comments="", encoding="utf-8")

    def to_pandas(self, names=None):
        """The named variables (default: every name) as a pandas DataFrame, for analysis.

        Indexed by time in s (index name "time"), one column per dotted name; `df.attrs["units"]` maps
        each column (and "time") to its unit. pandas is an optional extra: `pip install "mechnet[pandas]"`.
        """
        try:
            import pandas as pd
        except ImportError:
            raise MechnetError('to_pandas() needs pandas, an optional extra of mechnet: '
                               'pip install "mechnet[pandas]" (or pip install pandas)') from None
        names = self._checked(names, "to_pandas(names=...)", self.names)
        frame = pd.DataFrame({n: self[n] for n in names}, index=pd.Index(self.t, name="time"))
        frame.attrs["units"] = {"time": "s", **{n: self._unit(n) for n in names}}
        return frame

    def plot(self, names=None, ax=None, *, title=None, reference=None):
        """Plot named variables against time (default: the first six states); returns the matplotlib Figure.

        Curves share an axis only when they share a unit: one subplot per unit (in the order the names
        first use it), stacked on a common time axis and labelled with the unit, so a 0.2 m piston is not
        a flat line beside a 600 rad crank. Every event of the run is a thin vertical line on each
        subplot, one colour per kind, named once in the top legend. A failed run keeps its red title.

        - title: the figure's title; default the model's name (`res.title`), none when drawing into `ax`.
        - reference: {name: values on `res.t`} drawn dashed over the curve of that (plotted) name.
        - ax: the Axes to draw into, one per unit in that order (a single Axes for a single unit);
          default a new figure.
        """
        import matplotlib.pyplot as plt

        names = self._checked(names, "plot(names)", self.state_names[:6])
        if not names:
            raise MechnetError("plot(names): this model has no states to plot by default; name the variables")
        groups: dict[str, list] = {}
        for n in names:
            groups.setdefault(self._unit(n), []).append(n)
        reference = self._reference(reference, names)
        if ax is None:
            fig, axes = plt.subplots(len(groups), 1, sharex=True, squeeze=False, layout="constrained",
                                     figsize=(8, 1.2 + 2.4 * len(groups)))
            axes = list(axes[:, 0])
            title = self.title if title is None else title
        else:
            axes = _given_axes(ax, list(groups))
            fig = axes[0].figure
            if len(axes) == 1 and len(groups) > 1:      # one Axes given: every unit in it, as before
                groups = {", ".join(groups): [n for group in groups.values() for n in group]}
        for axis, (unit, group) in zip(axes, groups.items()):
            for n in group:
                line, = axis.plot(self.t, self[n], label=n)
                if n in reference:
                    axis.plot(self.t, reference[n], "--", color=line.get_color(), linewidth=3.0, alpha=0.4,
                              zorder=line.get_zorder() - 0.1, label=f"{n} reference")
            axis.set_ylabel(unit)
            axis.grid(True, alpha=0.3)
        self._mark_events(axes)
        for axis in axes:
            axis.legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("time [s]")
        if title:
            fig.suptitle(textwrap.fill(str(title), 100), fontsize="medium")
        if self.failure is not None:
            axes[0].set_title(f"integration failed at t = {self.t[-1]:.6g} s", color="red")
        return fig

    def _reference(self, reference, names: list) -> dict:
        """plot(reference=...) as {plotted name: values on res.t}."""
        out = {}
        for n, values in mapping(reference, "plot(reference=...)").items():
            if n not in self._column:
                raise UnknownNameError(f"plot(reference=...): {unknown_name(n, self.names)}")
            if n not in names:
                raise MechnetError(f"plot(reference=...): {n!r} is not among the plotted names "
                                   f"({', '.join(names)}); plot it too or leave its reference out")
            try:
                out[n] = np.broadcast_to(np.asarray(values, dtype=float), self.t.shape)
            except (TypeError, ValueError):
                raise MechnetError(f"plot(reference=...)[{n!r}]: expected values on res.t ({self.t.size} "
                                   f"times), got shape {np.shape(values)}") from None
        return out

    def _mark_events(self, axes) -> None:
        """Events as vertical lines over the full height of each subplot (one collection per kind)."""
        times: dict[str, list] = {}
        for event in self.events:
            times.setdefault(event.kind, []).append(event.t)
        for k, axis in enumerate(axes):
            for kind, ts in times.items():
                axis.vlines(ts, 0.0, 1.0, transform=axis.get_xaxis_transform(), linewidth=0.8, alpha=0.7,
                            colors=EVENT_COLORS.get(kind, "0.3"),
                            label=f"{kind} event" if k == 0 else "_nolegend_")

    def __repr__(self):
        status = "ok" if self.success else f"FAILED: {self.failure}"
        return f"<Result {len(self.t)} points, t = {self.t[0]:g}..{self.t[-1]:g} s, {status}>"


def _column_label(name: str, unit: str) -> str:
    """A CSV column: `name [unit]`; the unit is the last bracket (a name may hold an index, r_0[1])."""
    return f"{name} [{unit}]"


def _given_axes(ax, units: list) -> list:
    """`plot(ax=...)`: one Axes (every unit drawn in it) or one per unit group, else an error saying how
    many are needed."""
    from matplotlib.axes import Axes

    if isinstance(ax, Axes):
        return [ax]
    axes = list(np.ravel(np.asarray(ax, dtype=object)))
    if len(axes) != len(units) or not all(isinstance(a, Axes) for a in axes):
        raise MechnetError(f"plot(ax=...): the names have {len(units)} unit(s) ({', '.join(units)}), each drawn "
                           f"in its own axes: pass {len(units)} matplotlib Axes (got {ax!r:.80}), or leave ax "
                           f"out for a new figure")
    return axes
