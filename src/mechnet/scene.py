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
  first line).
"""
from __future__ import annotations

import importlib.util
import itertools
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

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

    def model(self):
        """Call ``build()`` and check that it gave a Model, so errors name the scene file."""
        from mechnet.core.model import Model  # lazy: loading a scene must not need the compiler

        model = self.build()
        if not isinstance(model, Model):
            raise SceneError(
                f"scene file {self.path}: build() returned {type(model).__name__}, "
                f"expected a mechnet.Model (did build() forget to `return m`?)"
            )
        return model


def load_scene(path: str | Path) -> Scene:
    """Import the scene file at `path` and return its `Scene`.

    Raises SceneError, naming the file, when the file is missing, fails to
    import, or does not define a callable ``build`` (or has malformed
    ``t_end``, ``plot`` or ``reference``).
    """
    path = Path(path).expanduser().resolve()
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
    try:
        spec.loader.exec_module(module)
    except MechnetError as exc:
        sys.modules.pop(module_name, None)
        raise SceneError(f"scene file {path} failed while importing: {exc}") from exc
    except Exception as exc:
        sys.modules.pop(module_name, None)
        raise SceneError(
            f"scene file {path} failed while importing: {type(exc).__name__}: {exc}"
        ) from exc

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
    )


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
    if isinstance(plot, str):
        plot = [plot]
    try:
        names = tuple(plot)
    except TypeError:
        raise SceneError(f"scene file {path}: `plot` must be a list of dotted names") from None
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise SceneError(f"scene file {path}: `plot` entries must be dotted names (str), got {bad!r}")
    return names


def _description(module) -> str:
    description = getattr(module, "description", None)
    if description is not None:
        return str(description).strip()
    doc = (module.__doc__ or "").strip()
    return doc.split("\n\n", 1)[0].replace("\n", " ").strip()
