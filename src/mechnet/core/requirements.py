"""Relations between a component's parameters (mu_s >= mu_k, phi_max > phi_min), declared once.

A component lists them in `requirements()` as data — two of its parameters and a comparison — rather
than as code in `check()`, because code runs only where the component object exists: at construction.
A tunable parameter changed later (`simulate(params=)`, `cm.prepare`, a model loaded from an export, an
FMU's parameter setter) went unchecked, and a friction coefficient below its kinetic one or reversed
stop limits ran, or failed with a misleading message (issue 31). As data the same declaration travels
with the compiled model (`dae.info["parameter_requirements"]`), into model.json, and into the FMU's C
wrapper, and `broken` words every refusal alike.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass

from .errors import ParameterError

# comparison -> (the test, how a value that fails it stands to the other)
COMPARISONS = {">=": (operator.ge, "below"), ">": (operator.gt, "not above")}


@dataclass(frozen=True)
class Requirement:
    """`lhs op rhs` between two parameters of one component (their keys), and why it must hold."""

    lhs: str
    op: str
    rhs: str
    why: str

    def __post_init__(self):
        if self.op not in COMPARISONS:
            raise ValueError(f"Requirement op {self.op!r}: expected one of {', '.join(COMPARISONS)}")


def broken(owner: str, entry: dict, lhs: float, rhs: float) -> str | None:
    """The refusal of `entry` (a compiled requirement, `compiled`) at the values lhs, rhs, or None."""
    holds, fails = COMPARISONS[entry["op"]]
    if holds(lhs, rhs):
        return None
    a, b = entry["lhs"].rsplit(".", 1)[-1], entry["rhs"].rsplit(".", 1)[-1]
    return (f"{owner}: {a} = {lhs:g} is {fails} {b} = {rhs:g}; {a} must be {entry['op']} {b} "
            f"({entry['why']})")


def compiled(component, path: str) -> list[dict]:
    """The component's requirements as the compiled model keeps them (JSON-ready): the dotted names of
    both sides, each side's folded value (None when tunable: read from the parameter vector), the
    comparison, why, and the owner to name. Only those a tunable parameter takes part in: the others
    were checked at construction and cannot change."""
    out = []
    for req in component.requirements():
        sides = {}
        for side in ("lhs", "rhs"):
            key = getattr(req, side)
            sides[side] = f"{path}.{key}"
            sides[f"{side}_value"] = None if key in component.tunable else float(component._values[key])
        if sides["lhs_value"] is None or sides["rhs_value"] is None:
            out.append({**sides, "op": req.op, "why": req.why, "owner": f"{path} ({type(component).__name__})"})
    return out


def check_component(component, label: str) -> None:
    """A component's requirements at its construction values (ParameterError naming it)."""
    for req in component.requirements():
        entry = {"lhs": req.lhs, "rhs": req.rhs, "op": req.op, "why": req.why}
        values = [component.tunable[k][1] if k in component.tunable else component._values[k]
                  for k in (req.lhs, req.rhs)]
        problem = broken(label, entry, *values)
        if problem:
            raise ParameterError(problem)


def check_values(entries, values: dict, where: str) -> None:
    """Every compiled requirement at the parameter values `values` (dotted name -> number; a side with a
    folded value keeps it). `where` says where the values entered ("simulate(params=...)")."""
    for entry in entries:
        lhs, rhs = (entry[f"{s}_value"] if entry[f"{s}_value"] is not None else values[entry[s]]
                    for s in ("lhs", "rhs"))
        if not (math.isfinite(lhs) and math.isfinite(rhs)):
            continue                           # (a non-finite value is refused, by name, before this)
        problem = broken(entry["owner"], entry, lhs, rhs)
        if problem:
            raise ParameterError(f"{where}: {problem}")


def onto_requirements(entries, values: dict, freed, tolerance: float = 1e-6) -> dict:
    """`values` (dotted name -> number) with each freed parameter that breaks a requirement by at most
    `tolerance` (relative to the larger side, absolute below 1) moved onto it: an optimiser keeps its
    constraints only to its tolerance (IPOPT left a freed mu_s 7e-9 below mu_k, which simulate then
    refused). A strict requirement gets the next number beyond the other side. Larger breaks stay, for
    the check that reads the values to name them."""
    out = dict(values)
    for entry in entries:
        lhs, rhs = (entry[f"{s}_value"] if entry[f"{s}_value"] is not None else out[entry[s]] for s in ("lhs", "rhs"))
        if broken("", entry, lhs, rhs) is None or abs(lhs - rhs) > tolerance * max(1.0, abs(lhs), abs(rhs)):
            continue
        strict = entry["op"] == ">"
        if entry["lhs_value"] is None and entry["lhs"] in freed:
            out[entry["lhs"]] = math.nextafter(rhs, math.inf) if strict else rhs
        elif entry["rhs_value"] is None and entry["rhs"] in freed:
            out[entry["rhs"]] = math.nextafter(lhs, -math.inf) if strict else lhs
    return out
