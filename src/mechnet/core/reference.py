"""The component reference (docs/components.md), generated from the declarations.

Why generated: a hand-written list of arguments went stale (docs/conventions.md
once called ConstantTorque's `tau_constant` "tau"). The reference is rendered
from the same rows as each class's docstring (core/signatures.py), and
tests/unit/test_component_reference.py fails when the file and the code differ.

Regenerate with `python -m mechnet.core.reference > docs/components.md`.
"""
from __future__ import annotations

import importlib
import re

from .component import Component
from .signatures import argument_rows, connector_rows, default_text, variable_rows

COMMAND = "python -m mechnet.core.reference > docs/components.md"
DOMAINS = [("Rotational", "mechnet.components.rotational", "rot"),
           ("Translational", "mechnet.components.translational", "tr"),
           ("Multibody", "mechnet.components.multibody", "mb")]

KINDS = {"Parameters": "parameter", "Flags": "flag", "Inputs": "input"}

HEADER = f"""# Component reference

Generated from the components' declarations; do not edit by hand. Regenerate with

    {COMMAND}

(tests/unit/test_component_reference.py fails when this file is out of date).

A component is built as `Class("name", keyword=value, ...)`: the name first,
every other argument by keyword. Besides the arguments listed, each variable
`v` of a component takes `v_start=` (a fixed start value), `v_guess=` (a Newton
guess) and `v_nominal=` (its typical magnitude, which scales the tolerance). A
scalar parameter given as `mechnet.tunable(value)` stays a symbol instead of
being folded into the equations. An input takes a number or a signal
(`mechnet.components.signals`); `simulate(inputs=...)` can also set it at run
time. `help(Class)` and `inspect.signature(Class)` show the same, with the
variables' descriptions. Sign conventions: [conventions.md](conventions.md).
"""


def components(module) -> list[type]:
    """The concrete components a domain module exports, in its `__all__` order."""
    found = [getattr(module, name) for name in module.__all__]
    return [c for c in found if isinstance(c, type) and issubclass(c, Component) and not c.abstract]


def _cell(text: str) -> str:
    """Text safe inside a table cell: `|` would split it, `*` would start emphasis."""
    return text.replace("|", r"\|").replace("*", r"\*")


def _code(text: str) -> str:
    """A code span (kept literal: only `|` needs escaping inside a table)."""
    return f"`{text}`".replace("|", r"\|") if text else ""


def component_section(cls, alias: str) -> str:
    """One component: heading, first paragraph of its docstring, its argument table, connectors, variables."""
    summary = " ".join(cls._own_doc.split("\n\n")[0].split())
    lines = [f"### {alias}.{cls.__name__}", "", summary, ""]
    rows = argument_rows(cls)
    if rows:
        lines += ["| Argument | Kind | Default | Unit | Description |", "|---|---|---|---|---|"]
        for group, key, default, unit, shape, doc in rows:
            kind = ", ".join(t for t in (KINDS[group], shape) if t)
            value = default_text(default)
            value = value if value == "required" else _code(value)
            lines.append(f"| `{key}` | {kind} | {value} | {_code(unit)} | {_cell(doc)} |")
        lines.append("")
    else:
        lines += ["No parameters.", ""]
    connectors = [f"`{key}` ({', '.join(t for t in (label, only) if t)})"
                  for key, label, doc, only in connector_rows(cls)]
    if connectors:
        lines += ["Connectors: " + ", ".join(connectors) + ".", ""]
    variables = [f"`{key}` ({_code(unit)}, {kind})" for key, unit, kind, doc in variable_rows(cls)]
    if variables:
        lines += ["Variables: " + ", ".join(variables) + ".", ""]
    return "\n".join(lines)


def component_reference() -> str:
    """docs/components.md: one section per domain, one argument table per component."""
    parts = [HEADER]
    for title, module_name, alias in DOMAINS:
        module = importlib.import_module(module_name)
        parts.append(f"## {title}\n\n`import {module_name} as {alias}`\n")
        parts += [component_section(cls, alias) for cls in components(module)]
    return re.sub(r"\n{3,}", "\n\n", "\n".join(parts)).rstrip() + "\n"


if __name__ == "__main__":
    print(component_reference(), end="")
