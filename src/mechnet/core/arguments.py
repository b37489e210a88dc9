"""Checks of the arguments users pass to the public entry points, in one place.

Why one place: the same mistake (a list where a mapping belongs, 2.5 steps, a directory as a file) must
get the same named error wherever it is made; per-call checks drifted apart (issue 16 counted 100 bad
inputs escaping as bare TypeError/AttributeError). Numbers: `declarations.finite_number`.
"""
from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from .declarations import not_a_number
from .errors import MechnetError


def mapping(value, what: str, error=MechnetError) -> dict:
    """A {name: value} mapping (None: empty), or `error` naming the argument."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise error(f"{what} takes a mapping {{name: value}}, got {type(value).__name__} {value!r:.60}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise error(f"{what}: names must be dotted strings such as 'j1.phi', got {bad[0]!r}")
    return dict(value)


def whole_number(value, what: str, minimum: int, error=MechnetError) -> int:
    """An int of at least `minimum` (2.0 is fine, 2.5, True and '2' are not)."""
    if not_a_number(value) or value is None:
        raise error(f"{what} = {value!r} must be a whole number of at least {minimum}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise error(f"{what} = {value!r} must be a whole number of at least {minimum}") from None
    if not (np.isfinite(number) and number == int(number) and number >= minimum):
        raise error(f"{what} = {value!r} must be a whole number of at least {minimum}")
    return int(number)


def flag(value, what: str, error=MechnetError, allow_none: bool = False) -> bool | None:
    """True or False (None too where it means 'decide for me')."""
    if value is None and allow_none:
        return None
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{what} = {value!r} must be True or False" + (" (or None)" if allow_none else ""))
    return bool(value)


def name_list(value, what: str, error=MechnetError) -> list[str]:
    """Dotted names: one string is one name (not its characters), else a sequence of strings."""
    if isinstance(value, str):
        return [value]
    try:
        names = list(value)
    except TypeError:
        raise error(f"{what} takes a dotted name or a list of them, got {type(value).__name__}") from None
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise error(f"{what}: names must be dotted strings such as 'j1.phi', got {bad[0]!r}")
    return names


def output_file(path, what: str, error=MechnetError) -> str:
    """A path a file can be written to: not a directory, in a directory that exists."""
    try:
        path = os.fspath(path)
    except TypeError:
        raise error(f"{what} = {path!r} is not a file path") from None
    if os.path.isdir(path):
        raise error(f"{what} = {path!r} is a directory; give a file name inside it")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise error(f"{what} = {path!r}: the folder {folder!r} does not exist")
    return path
