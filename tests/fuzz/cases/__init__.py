"""Fuzz cases, one module per API area; `collect()` gathers them in a fixed order (the sample is every
N-th of this order)."""
from __future__ import annotations

import importlib

AREAS = ("components", "connections", "simulate", "starts", "tables", "analysis", "ocp", "export", "fmu",
         "sweep", "accuracy", "cli")


def collect() -> list:
    cases = []
    for area in AREAS:
        cases += importlib.import_module(f"fuzz.cases.{area}").collector().cases
    ids = [c.id for c in cases]
    duplicated = {i for i in ids if ids.count(i) > 1}
    if duplicated:
        raise ValueError(f"duplicate fuzz case ids: {sorted(duplicated)[:5]}")
    return cases
