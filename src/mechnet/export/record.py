"""model.json's schema: every entry `load` reads, checked in one place before a model is built from it.

A record edited by hand or mixed up with another export's fails here, with an ExportError naming the key
and the entry, rather than later as a KeyError, a TypeError or a CasADi assertion deep inside a run.
`check_record` looks at the record alone (types, finite numbers, names, the declared checks of parameter
values); `check_fit` at the record against the functions read beside it (names and sizes of every input
and output). Neither can tell a crafted folder from a real one (docs/export.md, "What is trusted").
"""
from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path

from ..core.errors import MechnetError
from .contract import FORMAT_VERSION, ExportError

#: the dependency patterns an export records (`contract.dependencies`, `contract._init_dependencies`)
DEPENDENCIES = ([f"{a}_{b}" for a in ("xdot", "y", "z") for b in "xup"]
                + [f"init_{a}_{b}" for a in ("x", "xdot", "y") for b in "supd"])
_HEX = re.compile(r"[0-9a-f]{64}")


def _type(value) -> str:
    return {type(None): "null", bool: "true/false", str: "a string", list: "a list", dict: "a mapping"}.get(
        type(value), "a number" if isinstance(value, (int, float)) else type(value).__name__)


class _Checker:
    def __init__(self, file: Path):
        self.file = file

    def fail(self, key: str, why: str):
        raise ExportError(f"load: {self.file} {key}: {why}")

    def of(self, value, kind, key: str, what: str):
        if isinstance(value, bool) and kind is not bool or not isinstance(value, kind):
            self.fail(key, f"must be {what}, not {_type(value)} ({value!r:.80})")
        return value

    def number(self, value, key: str, positive: bool = False) -> float:
        self.of(value, (int, float), key, "a finite number")
        if not math.isfinite(value) or positive and value <= 0:
            self.fail(key, f"must be a finite number{' > 0' if positive else ''}, not {value!r}")
        return value

    def entries(self, record: dict, key: str, fields: dict, optional: bool = False) -> list:
        """record[key] as a list of mappings, each field checked by `fields` (name -> check(value, where))."""
        if key not in record:
            if optional:
                return []
            self.fail(repr(key), "is missing")
        items = self.of(record[key], list, repr(key), "a list")
        for k, entry in enumerate(items):
            self.of(entry, dict, f"{key}[{k}]", "a mapping")
            for field, check in fields.items():
                if field not in entry:
                    self.fail(f"{key}[{k}][{field!r}]", "is missing")
                check(entry[field], f"{key}[{k}][{field!r}]")
        return items

    def unique(self, names: list, key: str, within: set | None = None, what: str = "") -> None:
        seen = set()
        for k, name in enumerate(names):
            if name in seen:
                self.fail(f"{key}[{k}]", f"{name!r} is listed twice")
            if within is not None and name not in within:
                self.fail(f"{key}[{k}]", f"{name!r} is not {what}")
            seen.add(name)


def read_format(record, file: Path) -> int:
    """The export format of a record, refused when it is none this mechnet reads (ExportError naming why)."""
    if not isinstance(record, dict):
        raise ExportError(f"load: {file} must hold a JSON mapping of the export's entries, not {_type(record)}")
    if "format" not in record:
        raise ExportError(f"load: {file} has no 'format' (the export format version): not a record mechnet "
                          f"wrote, or one cut short")
    version = record["format"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise ExportError(f"load: {file} 'format' must be a whole number (the export format version), not "
                          f"{_type(version)} ({version!r:.80})")
    if version < 1:
        raise ExportError(f"load: {file} 'format' = {version} is no export format (mechnet writes 1 to "
                          f"{FORMAT_VERSION})")
    if version > FORMAT_VERSION:
        raise ExportError(f"load: {file.parent} was written in export format {version} by a newer mechnet; this "
                          f"one reads formats up to {FORMAT_VERSION}: upgrade mechnet to load it")
    return version


def check_record(record: dict, file: Path) -> None:
    """Every entry of a kind="casadi" record `load` reads: types, finite numbers, names that are the model's,
    and parameter values within their declared checks and requirements (ExportError naming the key)."""
    from .load import check_named
    c = _Checker(file)
    text = lambda v, key: c.of(v, str, key, "a string")                       # noqa: E731
    number = c.number
    positive = lambda v, key: c.number(v, key, positive=True)                 # noqa: E731
    c.of(record.get("name"), str, "'name'", "a string (the model's name)")
    observed = c.entries(record, "observed", {"name": text, "unit": text, "kind": text, "nominal": positive})
    c.unique([v["name"] for v in observed], "observed")
    names = {v["name"] for v in observed}
    lists = {key: c.entries(record, key, {"name": text, "unit": text, field: check})
             for key, field, check in (("x", "nominal", positive), ("z", "nominal", positive),
                                       ("u", "default", number), ("p", "value", number), ("d", "start", number))}
    owned = {}
    for key, items in lists.items():
        c.unique([v["name"] for v in items], key, names, "an observed name (model.json 'observed')")
        for k, v in enumerate(items):
            if v["name"] in owned:
                c.fail(f"{key}[{k}]", f"{v['name']!r} is also listed in {owned[v['name']]!r}")
            owned[v["name"]] = key
    for k, v in enumerate(lists["p"]):
        for field in ("owner", "doc"):
            if field in v:
                text(v[field], f"p[{k}][{field!r}]")
        if v.get("check") is not None and check_named(text(v["check"], f"p[{k}]['check']")) is None:
            c.fail(f"p[{k}]['check']", f"{v['check']!r} is no parameter check of mechnet (an export names one of "
                                       f"mechnet.core.declarations, or 'mechnet.module:name'; null for a check of "
                                       f"the user's own)")
    for key in ("starts", "declared_starts"):
        items = c.entries(record, key, {"name": text, "value": number})
        c.unique([s["name"] for s in items], key, names, "an observed name (model.json 'observed')")
    guesses = c.of(record.get("guesses"), dict, "'guesses'", "a mapping of names to numbers")
    for name, value in guesses.items():
        if name not in names:
            c.fail(f"guesses[{name!r}]", "is not an observed name (model.json 'observed')")
        number(value, f"guesses[{name!r}]")
    zero = c.entries(record, "zero", {"label": text, "direction": lambda v, key: v in (-1, 0, 1) and not isinstance(
        v, bool) or c.fail(key, f"must be -1, 0 or 1, not {v!r:.80}")})
    for k, e in enumerate(zero):
        if "at_start" in e:
            c.of(e["at_start"], bool, f"zero[{k}]['at_start']", "true or false")
    for k, e in enumerate(c.of(record.get("time_events"), list, "'time_events'", "a list of [time, cause]")):
        if not isinstance(e, list) or len(e) != 2:
            c.fail(f"time_events[{k}]", f"must be [time, cause], not {e!r:.80}")
        number(e[0], f"time_events[{k}][0]")
        text(e[1], f"time_events[{k}][1]")
    for key in ("invariants", "alg_labels", "folded_parameters", "linear_tears"):
        if key == "linear_tears" and key not in record:
            continue
        for k, v in enumerate(c.of(record.get(key), list, repr(key), "a list of strings")):
            text(v, f"{key}[{k}]")
    c.unique(record["folded_parameters"], "folded_parameters")
    for k, name in enumerate(record["folded_parameters"]):
        if owned.get(name) == "p":
            c.fail(f"folded_parameters[{k}]", f"{name!r} is also a tunable parameter ('p')")
    z_names = {v["name"] for v in lists["z"]}
    c.unique(record.get("linear_tears", []), "linear_tears", z_names, "an algebraic variable ('z')")
    nx = len(lists["x"])
    for k, q in enumerate(c.of(record.get("quaternions", []), list, "'quaternions'", "a list")):
        if not isinstance(q, list) or len(q) != 4 or any(isinstance(i, bool) or not isinstance(i, int)
                                                         or not 0 <= i < nx for i in q):
            c.fail(f"quaternions[{k}]", f"must be 4 state indices in 0..{nx - 1}, not {q!r:.80}")
    _selection(c, record, [v["name"] for v in lists["x"]])
    _dependencies(c, record, {"x": nx, "xdot": nx, "z": len(lists["z"]), "y": len(observed), "u": len(lists["u"]),
                              "p": len(lists["p"]), "d": len(lists["d"]), "s": len(record["starts"])})
    _parameters(c, record, lists["p"])


def _selection(c: _Checker, record: dict, states: list) -> None:
    selection = c.of(record.get("selection"), dict, "'selection'", "a mapping")
    for field, kind, what in (("holds", bool, "true or false"), ("states", list, "a list of the states"),
                              ("reason", str, "a string")):
        if field not in selection:
            c.fail(f"selection[{field!r}]", "is missing")
        c.of(selection[field], kind, f"selection[{field!r}]", what)
    if selection["states"] != states:
        c.fail("selection['states']", f"must be the states model.json 'x' lists, {states}, not "
                                      f"{selection['states']!r:.200}")


_SIZED_BY = {"x": "'x'", "xdot": "'x'", "z": "'z'", "y": "'observed'", "u": "'u'", "p": "'p'", "d": "'d'",
             "s": "'starts'"}


def _dependencies(c: _Checker, record: dict, sizes: dict) -> None:
    """The dependency patterns an FMU made from the loaded model declares: [row, column] within the sizes."""
    deps = c.of(record.get("dependencies"), dict, "'dependencies'", "a mapping of patterns")
    for key in deps:
        if key not in DEPENDENCIES:
            c.fail(f"dependencies[{key!r}]", "is no dependency pattern an export writes")
    for key in DEPENDENCIES:
        if key not in deps:
            c.fail(f"dependencies[{key!r}]", "is missing")
        *_, rows, cols = key.split("_")
        for k, pair in enumerate(c.of(deps[key], list, f"dependencies[{key!r}]", "a list of [row, column]")):
            if not isinstance(pair, list) or len(pair) != 2 or any(
                    isinstance(i, bool) or not isinstance(i, int) for i in pair) \
                    or not (0 <= pair[0] < sizes[rows] and 0 <= pair[1] < sizes[cols]):
                c.fail(f"dependencies[{key!r}][{k}]", f"must be [row, column] within {sizes[rows]} x {sizes[cols]} "
                                                      f"(the sizes of {_SIZED_BY[rows]} and {_SIZED_BY[cols]}), "
                                                      f"not {pair!r:.80}")


def _parameters(c: _Checker, record: dict, p: list) -> None:
    """Parameter values within their declared checks, and the requirements between them, as at construction."""
    from ..core.requirements import COMPARISONS, check_values
    from .load import _declaration
    for k, entry in enumerate(p):
        declaration = _declaration(entry)
        if declaration is not None:
            try:
                declaration.validate(entry.get("owner", entry["name"]), entry["value"])
            except MechnetError as exc:
                c.fail(f"p[{k}]['value']", str(exc))
    values = {v["name"]: v["value"] for v in p}
    sides = lambda v, key: v is None or c.number(v, key)                      # noqa: E731
    text = lambda v, key: c.of(v, str, key, "a string")                       # noqa: E731
    entries = c.entries(record, "parameter_requirements",
                        {"lhs": text, "rhs": text, "lhs_value": sides, "rhs_value": sides, "why": text,
                         "owner": text, "op": lambda v, key: isinstance(v, str) and v in COMPARISONS or c.fail(
                             key, f"must be one of {', '.join(COMPARISONS)}, not {v!r:.80}")}, optional=True)
    for k, e in enumerate(entries):
        for side in ("lhs", "rhs"):
            if e[f"{side}_value"] is None and e[side] not in values:
                c.fail(f"parameter_requirements[{k}][{side!r}]", f"{e[side]!r} is not a tunable parameter ('p')")
    try:
        check_values(entries, values, "the parameter values model.json 'p' lists")
    except MechnetError as exc:
        c.fail("'parameter_requirements'", str(exc))


def check_fit(record: dict, fns: dict, file: Path) -> None:
    """The functions read beside the record take and give what it lists: the inputs each function of the
    contract has (`contract.py`) by name and size, and its outputs by shape (ExportError naming both)."""
    c = _Checker(file)
    n = {k: len(record[k]) for k in ("x", "z", "u", "p", "d", "observed", "starts", "invariants", "zero")}
    nx, nz, ny = n["x"], n["z"], n["observed"]
    size = {"t": 1, "x": nx, "z": nz, "z0": nz, "u": n["u"], "p": n["p"], "d": n["d"], "s": n["starts"],
            "w0": nx + nz, "dx": nx, "du": n["u"], "dp": n["p"]}
    key_of = {"x": "'x'", "z": "'z'", "z0": "'z'", "u": "'u'", "p": "'p'", "d": "'d'", "s": "'starts'",
              "w0": "'x' and 'z'", "dx": "'x'", "du": "'u'", "dp": "'p'", "t": "time"}
    args = ("t", "x", "z", "u", "p", "d")
    by_x = [(nx, n) for n in (nx, nz, n["u"], n["p"])]
    outputs = {"ode": [(nx, 1)], "alg": [(nz, 1)], "observed": [(ny, 1)], "invariants": [(n["invariants"], 1)],
               "zero": [(n["zero"], 1)], "init": [(nx, 1), (nz, 1), (1, 1)], "solve_alg": [(nz, 1), (1, 1)],
               "jac_ode": by_x, "jac_alg": [(nz, m) for _, m in by_x], "alg_jac": [(nz, nx + nz)],
               "forward": [(nx, 1), (ny, 1), (nz, 1)], "transition": [(nx, 1), (n["d"], 1)]}
    inputs = {"init": ("t", "u", "p", "d", "s", "w0"), "solve_alg": ("t", "x", "z0", "u", "p", "d"),
              "forward": (*args, "dx", "du", "dp")}
    listed = {"ode": "'x'", "alg": "'z' and 'alg_labels'", "observed": "'observed'", "invariants": "'invariants'",
              "zero": "'zero'", "transition": "'x' and 'd'"}
    named = [(name, f) for name, f in fns.items() if name not in ("transition", "rest")]
    named += [(f"transition_{k}", f) for k, f in enumerate(fns["transition"])]
    named += [(f"rest_{k}", f) for k, f in enumerate(fns["rest"]) if f is not None]
    for name, f in named:
        role = name.rsplit("_", 1)[0] if name.startswith(("transition_", "rest_")) else name
        role = "transition" if role == "rest" else role
        where = f"files[{name!r}]" if role == name else f"files[{name.split('_')[0]!r}][{name.split('_')[1]}]"
        want = inputs.get(role, args)
        if tuple(f.name_in()) != want:
            c.fail(where, f"its function takes ({', '.join(f.name_in())}), not the contract's ({', '.join(want)})")
        for k, arg in enumerate(want):
            if f.numel_in(k) != size[arg]:
                c.fail(where, f"its function takes {f.numel_in(k)} values of {arg}; model.json {key_of[arg]} "
                              f"lists {size[arg]}")
        shapes = [tuple(f.size_out(k)) for k in range(f.n_out())]
        if role in outputs and [_empty(s) for s in shapes] != [_empty(s) for s in outputs[role]]:
            c.fail(where, f"its function gives outputs of shapes {shapes}; model.json "
                          f"{listed.get(role, 'x, z, u, p, observed')} make them {outputs[role]}")
    if len(record["alg_labels"]) != nz:
        c.fail("'alg_labels'", f"lists {len(record['alg_labels'])} equations for the {nz} algebraic variables "
                               f"of 'z'")
    if len(fns["transition"]) != n["zero"]:
        c.fail("'zero'", f"lists {n['zero']} events, and files['transition'] {len(fns['transition'])} transitions")


def _empty(shape: tuple) -> tuple:
    """A shape, with every empty one alike: CasADi writes an empty output as 1×0 or 0×1 by how it was built."""
    return (0, 0) if 0 in shape else shape


def sha256(file: Path) -> str:
    return hashlib.sha256(Path(file).read_bytes()).hexdigest()


def check_hashes(record: dict, members: dict, file: Path) -> None:
    """The files an export wrote, by the SHA-256 its record holds ("sha256"; an export written before mechnet
    recorded them has none, and is read unchecked): a file from another export is refused, naming it. This
    catches a folder mixing two exports by accident, not one made to pass (the record is the folder's too)."""
    if "sha256" not in record:
        return
    c = _Checker(file)
    hashes = c.of(record["sha256"], dict, "'sha256'", "a mapping of file names to SHA-256 digests")
    for name, digest in hashes.items():
        if not isinstance(digest, str) or not _HEX.fullmatch(digest):
            c.fail(f"sha256[{name!r}]", f"must be a SHA-256 digest (64 hexadecimal digits), not {digest!r:.80}")
    for name, member in members.items():
        if name not in hashes:
            c.fail("'sha256'", f"holds no digest of {name}, which the export wrote")
        if sha256(member) != hashes[name]:
            rebuilt = (f"; a library rebuilt from the export's sources loads once its entry is deleted from "
                       f"'sha256'" if Path(member).suffix == ".so" else "")
            raise ExportError(f"load: {member} does not match the SHA-256 model.json recorded for it at export: "
                              f"the folder mixes two exports, or the file was changed since (export again)"
                              f"{rebuilt}")
