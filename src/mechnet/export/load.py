"""`mechnet.export.load(path)`: an exported model back, without the scene code that built it."""
from __future__ import annotations

import sys
import json
import warnings
from pathlib import Path

import casadi as ca

from ..caches import BUILD_LOCK
from ..compile.artifacts import Selection, SemiExplicitDAE
from ..compile.compiled import CompiledModel
from .contract import FORMAT_VERSION, ExportError


class ExportWarning(UserWarning):
    """A loaded model that may not serve every run its scene served (a re-selection it cannot make)."""


def read_record(path) -> dict:
    """model.json of an export, checked: present, readable, and of a format this mechnet reads."""
    path = Path(path)
    record_file = path / "model.json"
    if not record_file.is_file():
        raise ExportError(f"load: {path} holds no model.json; give the directory cm.export() wrote")
    try:
        record = json.loads(record_file.read_text())
    except (OSError, ValueError) as exc:
        raise ExportError(f"load: {record_file} cannot be read: {exc}") from None
    version = record.get("format")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise ExportError(f"load: {path} was written in export format {version!r} by a newer mechnet; this one "
                          f"reads formats up to {FORMAT_VERSION}: upgrade mechnet to load it")
    return record


def load(path) -> "LoadedModel":
    """The model of a kind="casadi" export: it simulates, linearises and exports again like the
    compiled model it came from (the same functions, evaluated bitwise alike), with the choice of
    states the export holds (`model.json` "selection")."""
    path = Path(path)
    record = read_record(path)
    if record.get("kind") != "casadi":
        hint = (" (a kind='c' export: mechnet.export.load_library gives its functions)"
                if record.get("kind") == "c" else "")
        raise ExportError(f"load: {path} is a kind={record.get('kind')!r} export; load reads kind='casadi'{hint}")
    with BUILD_LOCK:
        fns = {name: ca.Function.load(str(path / file)) for name, file in record["files"].items()
               if name not in ("transition", "rest")}
        fns["transition"] = tuple(ca.Function.load(str(path / f)) for f in record["files"]["transition"])
        fns["rest"] = tuple(None if f is None else ca.Function.load(str(path / f))
                            for f in record["files"].get("rest", [None] * len(fns["transition"])))
    selection = record["selection"]
    if not selection["holds"]:
        warnings.warn(f"model {record['name']!r} loaded from {path} keeps the states {', '.join(selection['states'])} "
                      f"throughout, but its scene may need another choice during a run ({selection['reason']}); "
                      f"a run that needs one fails where that choice becomes singular", ExportWarning, stacklevel=2)
    return LoadedModel(record, _dae(record, fns), fns)


def load_library(path) -> dict:
    """The functions of a kind="c" export, from its shared library (CasADi `external`), by contract
    name: "ode", "alg", ..., "transition_0", ..."""
    path = Path(path)
    record = read_record(path)
    if record.get("kind") != "c":
        raise ExportError(f"load_library: {path} is a kind={record.get('kind')!r} export, not kind='c'")
    library = path / record["files"]["library"]
    if not library.is_file():
        raise ExportError(f"load_library: {library} is missing; build {record['files']['source']} into it")
    with BUILD_LOCK:
        return {name: ca.external(symbol, str(library)) for name, symbol in record["files"]["functions"].items()}


def _dae(record: dict, fns: dict) -> SemiExplicitDAE:
    """The compiled model's record rebuilt around the loaded functions, with fresh symbols."""
    def symbols(key):
        items = record[key]
        return ca.vertcat(*[ca.SX.sym(v["name"]) for v in items]) if items else ca.SX(0, 1)

    with BUILD_LOCK:
        t, x, z, u, p, d = ca.SX.sym("t"), *(symbols(k) for k in "xzupd")
    names = {k: tuple(v["name"] for v in record[k]) for k in "xzupd"}
    checks = {v["name"]: (_declaration(v), v.get("owner", v["name"])) for v in record["p"]}
    info = {"alg_labels": tuple(record["alg_labels"]), "linear_tears": tuple(record.get("linear_tears", ())),
            "folded_parameters": tuple(record["folded_parameters"]),
            "parameter_requirements": tuple(record.get("parameter_requirements", ())),
            "nominal": {v["name"]: v["nominal"] for v in record["observed"]}, "parameter_checks": checks,
            "solved": 0, "torn": len(record["z"]), "observed_only": 0,
            "quaternions": tuple(tuple(index) for index in record.get("quaternions", ())),
            "zero_at_start": tuple(bool(e.get("at_start", False)) for e in record["zero"]),
            "rest_transition": tuple(fns.get("rest", ()))}
    return SemiExplicitDAE(
        name=record["name"], t=t, x=x, z=z, u=u, p=p, d=d,
        x_names=names["x"], z_names=names["z"], u_names=names["u"], p_names=names["p"], d_names=names["d"],
        ode=fns["ode"], alg=fns["alg"], observed=fns["observed"],
        observed_names=tuple(v["name"] for v in record["observed"]),
        zero=fns["zero"], transition=fns["transition"], invariants=fns["invariants"],
        invariant_names=tuple(record["invariants"]),
        selections=(Selection(names["x"], names["z"], fns["ode"], fns["alg"], fns["observed"]),),
        x_nominal=tuple(v["nominal"] for v in record["x"]), z_nominal=tuple(v["nominal"] for v in record["z"]),
        units={v["name"]: v["unit"] for v in record["observed"]},
        starts={s["name"]: s["value"] for s in record["declared_starts"]},
        guesses=dict(record["guesses"]),
        u_default=tuple(v["default"] for v in record["u"]), p_value=tuple(v["value"] for v in record["p"]),
        d_value=tuple(v["start"] for v in record["d"]),
        time_events=tuple((tt, cause) for tt, cause in record["time_events"]),
        zero_labels=tuple(e["label"] for e in record["zero"]),
        zero_directions=tuple(e["direction"] for e in record["zero"]), info=info)


def check_named(where: str):
    """The parameter check an export names (a name in core/declarations.py, or "module:name" elsewhere in
    mechnet), or None. Nothing is imported on the file's word, and only a function marked as a
    parameter check is returned (`declarations.parameter_check`)."""
    from ..core import declarations
    module, _, name = where.rpartition(":")
    if module and not module.startswith("mechnet."):
        return None
    check = getattr(sys.modules.get(module) if module else declarations, name, None) if name else None
    return check if callable(check) and getattr(check, "is_parameter_check", False) else None


def _declaration(entry: dict):
    """A parameter's check as the scene declared it (by the name of one of core/declarations.py's checks,
    or "module:name" of one elsewhere in mechnet: `contract._check`), so a new value is refused as it was
    before export; None when the check was the user's own function (a new value must then be finite), or
    names anything that is not a parameter check of a module mechnet has loaded."""
    from ..core import declarations
    check = check_named(entry.get("check") or "")
    if check is None:
        return None
    decl = declarations.Param(entry["value"], unit=entry["unit"], doc=entry.get("doc", ""), check=check)
    decl.name = entry["name"].rsplit(".", 1)[-1]
    return decl


class LoadedModel(CompiledModel):
    """A compiled model read from a kind="casadi" export: everything that runs on the compiled model
    works (simulate, linearize, trim, functions, export); the compile stages are not there."""

    def __init__(self, record: dict, dae: SemiExplicitDAE, fns: dict):
        super().__init__(record["name"], {"dae": dae}, {}, None)
        self.record = record
        dae.info["_export_functions"] = {**fns, "metadata": {k: v for k, v in record.items()
                                                             if k not in ("kind", "files", "c_names")}}

    def summary(self) -> str:
        r = self.record
        kind = "explicit ODE" if not r["z"] else "index-1 DAE"
        return "\n".join([
            f"model {r['name']!r}: {kind}, loaded from an export (format {r['format']})",
            f"  states ({len(r['x'])}): {', '.join(v['name'] for v in r['x'])}",
            f"  algebraics ({len(r['z'])}): {', '.join(v['name'] for v in r['z']) or '-'}",
            f"  inputs ({len(r['u'])}): {', '.join(v['name'] for v in r['u']) or '-'}",
            f"  tunable parameters ({len(r['p'])}): {', '.join(v['name'] for v in r['p']) or '-'}",
            f"  modes ({len(r['d'])}): {', '.join(v['name'] for v in r['d']) or '-'}",
            f"  selection: {r['selection']['reason']}",
            f"  cost: {self.dae.ode.n_instructions()} instructions in ode, {self.dae.alg.n_instructions()} in alg",
        ])
