"""kind="fmu": a Model Exchange FMU (FMI 2.0 or 3.0) for Linux x86_64, sources inside.

CasADi's `DaeBuilder.export_fmu` was evaluated first (issue 19 note): it writes
FMI 3.0 only, never solves algebraic equations, writes units without their
definitions and variable names outside FMI's structured convention. So the FMI
wrapper is mechnet's own (`mechnet_fmu.c`, one file for both versions) around
CasADi's generated C of the contract; this module writes the model's tables
(`model_data.h`), `modelDescription.xml` (`model_description.py`) and the archive.

Variables: every observed name (value references 1..n in `observed` order),
`der(x)` for each state that has no such name already, and (FMI 3.0) one
variable per event indicator; reference 0 is time. Modes `d` are discrete Real
(Float64) variables with a start value, changed only by transitions.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import shutil
import tempfile
import zipfile
from importlib import resources
from pathlib import Path

import casadi as ca

from ..caches import BUILD_LOCK
from .contract import ARGS, ExportError
from .files import _TEMPORARY, API_NAMES, _parent, _record, _swap, _umask, compile_shared, generate_c
from .model_description import fmi_variables, model_description

WRAPPER = "mechnet_fmu.c"
PLATFORM = {2: "linux64", 3: "x86_64-linux"}
CALLED = ("init", "solve_alg", "ode", "observed", "zero", "zero_rates", "forward", "alg_jac")   # the wrapper's


def check_fmu_arguments(path: Path, fmi) -> None:
    """ExportError for an FMI version, platform or path an FMU cannot be written for."""
    if isinstance(fmi, bool) or not isinstance(fmi, int) or fmi not in (2, 3):
        raise ExportError(f"export(fmi={fmi!r}): FMI version must be 2 or 3")
    if (platform.system(), platform.machine()) != ("Linux", "x86_64"):
        raise ExportError(f"export(kind='fmu'): FMUs are built for Linux on x86_64 only, and this is "
                          f"{platform.system()} on {platform.machine()}; kind='c' or 'casadi' work here")
    if path.suffix != ".fmu":
        raise ExportError(f"export(kind='fmu'): the path {path} must end in .fmu")


def write_fmu(fns: dict, path: Path, fmi: int, overwrite: bool = False,
              names=None) -> Path:
    """Build the FMU in a temporary folder, zip it into a temporary sibling of `path` and rename that to
    `path` when complete (replacing a previous mechnet FMU only with overwrite, `files.replaceable`)."""
    check_fmu_arguments(path, fmi)
    names = names or API_NAMES
    meta = _record(fns, "fmu", {})
    ident = meta["c_names"][meta["name"]]
    meta["fmi"] = fmi
    meta["guid"] = "{" + _guid(meta) + "}"
    variables = fmi_variables(meta, fmi)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        sources = root / "sources"
        sources.mkdir()
        rests = tuple(f for f in fns["rest"] if f is not None)
        generate_c({**fns, "zero_rates": zero_rates_function(fns, meta)}, sources, ident, CALLED, rests)
        (sources / "model_data.h").write_text(model_data(meta, variables, ident, len(fns["transition"]), fmi,
                                                         [f is not None for f in fns["rest"]]))
        shutil.copy(resources.files(__package__) / WRAPPER, sources / WRAPPER)
        (root / "modelDescription.xml").write_text(model_description(meta, variables, ident, fmi,
                                                                     [f"{ident}.c", WRAPPER]))
        extra = root / "extra" / "org.mechnet"
        extra.mkdir(parents=True)
        (extra / "model.json").write_text(json.dumps({k: v for k, v in meta.items() if k != "files"}, indent=1))
        if fmi == 3:
            (sources / "buildDescription.xml").write_text(_build_description(ident))
        binaries = root / "binaries" / PLATFORM[fmi]
        binaries.mkdir(parents=True)
        compile_shared([sources / WRAPPER, sources / f"{ident}.c"], binaries / f"{ident}.so", [sources],
                       defines={"FMI_VERSION": str(fmi)})
        parent = _parent(path, names)
        try:
            handle, archive_path = tempfile.mkstemp(prefix=f".{path.name}{_TEMPORARY}", dir=parent)
        except OSError as exc:
            raise ExportError(f"export: cannot write in {parent} for {path} ({exc.strerror or exc})") from None
        os.close(handle)
        archive_path = Path(archive_path)
        try:
            with zipfile.ZipFile(archive_path, "w", zipfile.ZIP_DEFLATED) as archive:
                for file in sorted(root.rglob("*")):
                    if file.is_file():
                        archive.write(file, file.relative_to(root).as_posix())
            os.chmod(archive_path, 0o666 & ~_umask())
            _swap(archive_path, path, "fmu", overwrite, names)
        finally:
            if archive_path.exists():
                archive_path.unlink()
    return path


def _guid(meta: dict) -> str:
    digest = hashlib.sha256(json.dumps({k: v for k, v in meta.items() if k != "guid"}, sort_keys=True)
                            .encode()).hexdigest()
    return f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}"


def _c_array(ctype: str, name: str, values) -> str:
    values = list(values)
    body = ", ".join(_c_double(v) if ctype == "double" else str(v) for v in values) or "0"
    return f"static const {ctype} {name}[{max(len(values), 1)}] = {{{body}}};\n"


def _c_double(value) -> str:
    value = float(value)
    if math.isnan(value):
        raise ExportError("a value of the FMU's tables is NaN; a parameter, start or default must be a number")
    return repr(value) if math.isfinite(value) else ("INFINITY" if value > 0 else "-INFINITY")


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ") + '"'


def zero_rates_function(fns: dict, meta: dict) -> ca.Function:
    """(t, x, z, u, p, d) -> [g; ġ; g̈; their round-off]: the wrapper reads a condition's side on its
    boundary from its rates, and takes one within the round-off of the states in value and rates as at rest
    there, as the simulator does (`core/events.py`, `state_events._at_rest`). In SX where it can be."""
    from ..simulate.state_events import lie_rates, round_off
    nominal = {k: [v["nominal"] for v in meta[k]] for k in ("x", "z")}
    with BUILD_LOCK:
        for sym in (ca.SX, ca.MX):
            try:
                args = [sym.sym(n, *fns["zero"].size_in(k)) for k, n in enumerate(ARGS)]
                rates = lie_rates(fns["ode"], fns["alg"], fns["zero"], args)
                noise = round_off(rates, args, nominal["x"], nominal["z"])
                return ca.Function("zero_rates", args, [ca.densify(ca.vertcat(rates, noise))], list(ARGS),
                                   ["rates"])
            except (RuntimeError, NotImplementedError, TypeError):
                if sym is ca.MX:
                    raise


def model_data(meta: dict, variables: list, ident: str, n_transitions: int, fmi: int, has_rest=()) -> str:
    """model_data.h: sizes, defaults and the value-reference tables the wrapper reads."""
    n_var = len(variables)
    kind, index, setter, set_index, known, known_index = ([0] * (n_var + 1) for _ in range(6))
    for v in variables:
        r = v["vr"]
        kind[r], index[r] = v["get"]
        setter[r], set_index[r] = v.get("set", (0, 0))
        known[r], known_index[r] = v.get("known", (0, 0))
    sizes = {"NX": len(meta["x"]), "NZ": len(meta["z"]), "NU": len(meta["u"]), "NP": len(meta["p"]),
             "ND": len(meta["d"]), "NY": len(meta["observed"]), "NS": len(meta["starts"]), "NG": len(meta["zero"]),
             "NT": n_transitions, "NTE": len(meta["time_events"]), "NVAR": n_var}
    guesses = meta["guesses"]
    lines = [f"/* {meta['name']}: the tables of mechnet_fmu.c, written by mechnet.export.fmu */",
             f"#ifndef FMI_VERSION  /* the FMI API the sources build: FMI 2.0 has no build description */",
             f"#define FMI_VERSION {fmi}", "#endif",
             f'#include "{ident}.h"',
             f"#define MN_PREFIXED(name) {ident}_##name",
             f"#define MN_GUID {_c_string(meta['guid'])}",
             f"#define MN_STATES {_c_string(', '.join(v['name'] for v in meta['x']))}",
             *[f"#define MN_{k} {v}" for k, v in sizes.items()], ""]
    out = "\n".join(lines)
    out += _c_array("double", "mn_u_default", (v["default"] for v in meta["u"]))
    out += _c_array("double", "mn_p_default", (v["value"] for v in meta["p"]))
    out += _c_array("double", "mn_d_default", (v["start"] for v in meta["d"]))
    out += _c_array("double", "mn_s_default", (s["value"] for s in meta["starts"]))
    out += _c_array("double", "mn_guess", (guesses.get(v["name"], 0.0) for v in meta["x"] + meta["z"]))
    out += _c_array("double", "mn_x_nominal", (v["nominal"] for v in meta["x"]))
    out += _c_array("double", "mn_time_events", sorted({t for t, _ in meta["time_events"]}))
    out += _c_array("int", "mn_zero_direction", (e["direction"] for e in meta["zero"]))
    out += _c_array("int", "mn_zero_at_start", (int(e.get("at_start", False)) for e in meta["zero"]))
    out += (f"static const char *const mn_zero_labels[{max(len(meta['zero']), 1)}] = "
            f"{{{', '.join(_c_string(e['label']) for e in meta['zero']) or '0'}}};\n")
    names = ["time"] * (n_var + 1)
    for v in variables:
        names[v["vr"]] = v["name"]
    out += (f"static const char *const mn_vr_name[{n_var + 1}] = "
            f"{{{', '.join(_c_string(name) for name in names)}}};\n")
    states = {v["known"][1]: v["name"] for v in variables if v.get("known", (0, 0))[0] == 1}
    out += (f"static const char *const mn_x_name[{max(len(meta['x']), 1)}] = "
            f"{{{', '.join(_c_string(states[k]) for k in range(len(meta['x']))) or '0'}}};\n")
    for name, values in (("kind", kind), ("index", index), ("set", setter), ("set_index", set_index),
                         ("known", known), ("known_index", known_index)):
        out += _c_array("int", f"mn_vr_{name}", values)
    out += requirement_table(meta)
    # the transition functions, declared by the generated header: a table the wrapper walks
    entries = ", ".join(f"{{{ident}_transition_{k}, {ident}_transition_{k}_work, {ident}_transition_{k}_checkout, "
                        f"{ident}_transition_{k}_release}}" for k in range(n_transitions))
    out += f"#define MN_TRANSITIONS {{{entries or '{0, 0, 0, 0}'}}}\n"
    # the rest transitions (a plastic jump and rest modes ending an accumulation), {0} where a condition has none
    rests = ", ".join(f"{{{ident}_rest_{k}, {ident}_rest_{k}_work, {ident}_rest_{k}_checkout, "
                      f"{ident}_rest_{k}_release}}" if k < len(has_rest) and has_rest[k] else "{0, 0, 0, 0}"
                      for k in range(n_transitions))
    out += f"#define MN_RESTS {{{rests or '{0, 0, 0, 0}'}}}\n"
    return out


def requirement_table(meta: dict) -> str:
    """The requirements between parameters (`core/requirements.py`, model.json's "parameter_requirements")
    as C tables: each side a parameter index (or -1 and its folded value), strict or not, and the text
    the wrapper logs when a value set breaks one."""
    p_index = {v["name"]: k for k, v in enumerate(meta["p"])}
    entries = meta.get("parameter_requirements", [])
    sides = {side: [(p_index[e[side]], 0.0) if e[f"{side}_value"] is None else (-1, e[f"{side}_value"])
                    for e in entries] for side in ("lhs", "rhs")}
    out = f"#define MN_NR {len(entries)}\n"
    for side in ("lhs", "rhs"):
        out += _c_array("int", f"mn_req_{side}", (i for i, _ in sides[side]))
        out += _c_array("double", f"mn_req_{side}_value", (v for _, v in sides[side]))
    out += _c_array("int", "mn_req_strict", (int(e["op"] == ">") for e in entries))
    out += (f"static const char *const mn_p_names[{max(len(meta['p']), 1)}] = "
            f"{{{', '.join(_c_string(v['name']) for v in meta['p']) or '0'}}};\n")
    out += value_range_table(meta)
    texts = [f"{e['owner']}: {e['lhs'].rsplit('.', 1)[-1]} must be {e['op']} {e['rhs'].rsplit('.', 1)[-1]} "
             f"({e['why']})" for e in entries]
    return out + (f"static const char *const mn_req_text[{max(len(texts), 1)}] = "
                  f"{{{', '.join(_c_string(t) for t in texts) or '0'}}};\n")


def value_range_table(meta: dict) -> str:
    """Each parameter's range from its own check (`declarations.parameter_check`'s value_range) as C
    tables: lower bound, whether it is strict, upper bound and the text the wrapper logs. Checks of
    vectors and matrices (an axis, an inertia tensor), the user's own and none get (-inf, inf), where
    only a non-finite value is refused."""
    from ..core.declarations import value_range_text
    from .load import check_named
    ranges = []
    for v in meta["p"]:
        check = check_named(v.get("check") or "")
        value_range = getattr(check, "value_range", None)
        ranges.append((*value_range, value_range_text(check)) if value_range else (-math.inf, 0, math.inf, ""))
    out = _c_array("double", "mn_p_lower", (r[0] for r in ranges))
    out += _c_array("int", "mn_p_lower_strict", (int(r[1]) for r in ranges))
    out += _c_array("double", "mn_p_upper", (r[2] for r in ranges))
    return out + (f"static const char *const mn_p_rule[{max(len(ranges), 1)}] = "
                  f"{{{', '.join(_c_string(r[3]) for r in ranges) or '0'}}};\n")


def _build_description(ident: str) -> str:
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{ident}">\n'
            f'    <SourceFileSet>\n      <SourceFile name="{WRAPPER}"/>\n      <SourceFile name="{ident}.c"/>\n'
            f'      <PreprocessorDefinition name="FMI_VERSION" value="3"/>\n    </SourceFileSet>\n'
            f'  </BuildConfiguration>\n</fmiBuildDescription>\n')
