"""Scene files: plain Python files that build a model, loaded by path.

A scene file is what the CLI (`mechnet demo`, `mechnet simulate FILE`) and the
example tests run. Keeping it a plain Python module means a scene is written
with the ordinary API and can also be run on its own. It defines

- ``build() -> mechnet.Model`` (required);
- ``t_end`` — default simulation end time in s (float, default 10.0);
- ``reference(t)`` — optional closed-form or trusted solution: a dict mapping
  dotted names to arrays over the time array ``t``;
- ``plot`` — optional list of dotted names to plot;
- ``description`` — optional one-line text (defaults to the module docstring's
  first line);
- ``optimize(cm)`` — optional: solves an optimal control problem on the compiled
  model and returns its `mechnet.ocp.Solution` (`mechnet demo` runs it, prints
  its statistics and the replay's deviation, and plots it).
"""
from __future__ import annotations

import ast
import importlib.util
import itertools
import math
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

from mechnet.core.arguments import name_list
from mechnet.core.errors import MechnetError, SceneError

__all__ = ["Scene", "load_scene"]

DEFAULT_T_END = 10.0

# Module names must be unique so two scenes with the same stem (or the same
# scene loaded twice) never share or overwrite each other's module object.
_counter = itertools.count()


@dataclass(frozen=True)
class Scene:
    """A loaded scene file; `model()` builds a fresh, uncompiled Model each call."""

    name: str
    path: Path
    build: Callable[[], Any] = field(repr=False)
    t_end: float = DEFAULT_T_END
    reference: Optional[Callable[[Any], Mapping[str, Any]]] = field(default=None, repr=False)
    plot: tuple[str, ...] = ()
    description: str = ""
    optimize: Optional[Callable[[Any], Any]] = field(default=None, repr=False)

    def model(self):
        """Call ``build()`` and check that it gave a Model, so errors name the scene file."""
        from mechnet.core.model import Model  # lazy: loading a scene must not need the compiler

        try:
            model = self.build()
        except (Exception, SystemExit) as exc:  # the scene's own code: say where in the file
            raise scene_failure(self.path, exc, "build()", self.build) from exc
        if not isinstance(model, Model):
            raise SceneError(
                f"scene file {self.path}: build() returned {type(model).__name__}, "
                f"expected a mechnet.Model (did build() forget to `return m`?)"
            )
        return model

    def solve(self, cm):
        """The scene's `optimize(cm)`, its errors named with the scene file; the Solution it returns."""
        from mechnet.ocp import Solution

        try:
            solution = self.optimize(cm)
        except (Exception, SystemExit) as exc:
            raise scene_failure(self.path, exc, "optimize(cm)", self.optimize) from exc
        if not isinstance(solution, Solution):
            raise SceneError(f"scene file {self.path}: optimize(cm) returned {type(solution).__name__}, expected "
                             f"the mechnet.ocp.Solution of prob.solve(...)")
        return solution

    @property
    def title(self) -> str:
        """What the scene's plots are titled: its description, else its name (the PNG's name already)."""
        return self.description or self.name

    def check_plot(self, known) -> None:
        """Refuse a `plot` name that `known` (the compiled model's names) lacks, naming the `plot` line."""
        from mechnet.simulate.result import unknown_name

        known = set(known)
        for name in self.plot:
            if name not in known:
                raise SceneError(f"{self.path}:{_assignment_line(self.path, 'plot')}: "
                                 f"in `plot`: {unknown_name(name, known)}")

    def reference_errors(self, res) -> dict:
        """reference(t) on the result's grid: {name: (reference values, max |res[name] - reference|)}.

        Empty without a reference. NaN in a reference (a chaotic scene past its horizon) is skipped.
        """
        import numpy as np

        if self.reference is None:
            return {}
        try:
            reference = dict(self.reference(np.asarray(res.t)))
        except (Exception, SystemExit) as exc:
            raise scene_failure(self.path, exc, "reference(t)", self.reference) from exc
        errors = {}
        for name, expected in reference.items():
            if name not in res:
                from mechnet.simulate.result import unknown_name
                raise SceneError(f"{self.path}:{self.reference.__code__.co_firstlineno}: reference(t) "
                                 f"returns {unknown_name(name, res.names)}")
            expected = np.broadcast_to(np.asarray(expected, dtype=float), np.shape(res[name]))
            errors[name] = (expected, float(np.nanmax(np.abs(np.asarray(res[name]) - expected))))
        return errors


def scene_failure(path: Path, exc: BaseException, doing: str, function=None) -> SceneError:
    """An exception raised by a scene file's own code as one SceneError: `<file>:<line>: <cause>`.

    The line is the last traceback frame inside the scene file (a SyntaxError's own line); when the
    failure never entered the file (build() called with a missing argument), the line defining
    `function`. The original exception stays the __cause__, with its full traceback.
    """
    line = getattr(exc, "lineno", None) if isinstance(exc, SyntaxError) else None
    for frame in traceback.extract_tb(exc.__traceback__):
        if frame.filename and Path(frame.filename).resolve() == path:
            line = frame.lineno
    if line is None and function is not None:
        line = getattr(getattr(function, "__code__", None), "co_firstlineno", None)
    if isinstance(exc, SystemExit):
        cause = f"called sys.exit({exc.code!r})"
    elif isinstance(exc, MechnetError):
        cause = f"failed: {exc}"
    else:
        cause = f"failed: {type(exc).__name__}: {exc}"
    where = f"{path}:{line}" if line is not None else f"{path}"
    return SceneError(f"{where}: {doing} {cause}")


def _assignment_line(path: Path, name: str):
    """Line of the last top-level `name = ...` in the scene file ('?' if it cannot be found)."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return "?"
    lines = [node.lineno for node in tree.body if isinstance(node, (ast.Assign, ast.AnnAssign))
             and any(isinstance(t, ast.Name) and t.id == name
                     for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))]
    return lines[-1] if lines else "?"


def load_scene(path: str | Path) -> Scene:
    """Import the scene file at `path` and return its `Scene`.

    Raises SceneError, naming the file, when the file is missing, fails to
    import, or does not define a callable ``build`` (or has malformed
    ``t_end``, ``plot`` or ``reference``).
    """
    path = Path(path).expanduser().resolve()
    if path.is_dir():
        raise SceneError(f"scene file {path} is a directory; give a .py file that defines build()")
    if not path.is_file():
        raise SceneError(f"scene file {path} does not exist")

    module_name = f"_mechnet_scene_{next(_counter)}_{_identifier(path.stem)}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise SceneError(f"scene file {path} cannot be imported (expected a .py file)")
    module = importlib.util.module_from_spec(spec)
    # Registered before execution so that dataclasses, pickling and relative
    # look-ups inside the scene file see their own module.
    sys.modules[module_name] = module
    # The scene's folder is first on sys.path while it runs, so that it can import a helper module
    # beside it (as `python scene.py` would); sys.path is put back afterwards.
    folder = str(path.parent)
    sys.path.insert(0, folder)
    try:
        spec.loader.exec_module(module)
    except (Exception, SystemExit) as exc:
        sys.modules.pop(module_name, None)
        raise scene_failure(path, exc, "importing the scene file") from exc
    finally:
        try:
            sys.path.remove(folder)
        except ValueError:              # the scene took it off itself
            pass

    build = getattr(module, "build", None)
    if build is None:
        raise SceneError(f"scene file {path} defines no build() function returning a mechnet.Model")
    if not callable(build):
        raise SceneError(f"scene file {path}: `build` is a {type(build).__name__}, expected a function")

    return Scene(
        name=path.stem,
        path=path,
        build=build,
        t_end=_t_end(module, path),
        reference=_reference(module, path),
        plot=_plot(module, path),
        description=_description(module),
        optimize=_optimize(module, path),
    )


def _optimize(module, path: Path):
    optimize = getattr(module, "optimize", None)
    if optimize is not None and not callable(optimize):
        raise SceneError(f"scene file {path}: `optimize` must be a function optimize(cm) -> Solution")
    return optimize


def _identifier(text: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in text)


def _t_end(module, path: Path) -> float:
    value = getattr(module, "t_end", DEFAULT_T_END)
    try:
        t_end = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"scene file {path}: t_end = {value!r} is not a number") from None
    if not (math.isfinite(t_end) and t_end > 0.0):
        raise SceneError(f"scene file {path}: t_end = {value!r} must be a positive, finite time in s")
    return t_end


def _reference(module, path: Path):
    reference = getattr(module, "reference", None)
    if reference is not None and not callable(reference):
        raise SceneError(f"scene file {path}: `reference` must be a function reference(t) -> dict")
    return reference


def _plot(module, path: Path) -> tuple[str, ...]:
    plot = getattr(module, "plot", None)
    if plot is None:
        return ()
    return tuple(name_list(plot, f"scene file {path}: `plot`", SceneError))


def _description(module) -> str:
    description = getattr(module, "description", None)
    if description is not None:
        return str(description).strip()
    doc = (module.__doc__ or "").strip()
    return doc.split("\n\n", 1)[0].replace("\n", " ").strip()
