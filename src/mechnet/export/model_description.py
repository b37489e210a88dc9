"""modelDescription.xml for FMI 2.0 and 3.0 Model Exchange, from the contract's metadata.

The dependencies in ModelStructure are the structural sparsity of the
Jacobians (`contract.dependencies`): derivatives and outputs on states and
inputs; initial unknowns on start values, inputs and parameters.
"""
from __future__ import annotations

import re
from xml.sax.saxutils import quoteattr

# FMI's structured names: identifiers with 1-based array subscripts, joined by dots, or der(...)
_IDENT = r"[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+(,[0-9]+)*\])?"
STRUCTURED = re.compile(rf"^({_IDENT}(\.{_IDENT})*|der\({_IDENT}(\.{_IDENT})*(,[0-9]+)?\))$")
# mechnet's 0-based element subscripts
_SUBSCRIPT = re.compile(r"\[([0-9]+)\]")


def fmi_name(name: str) -> str:
    """A dotted mechnet name in FMI's 1-based convention: body.r_0[0] -> body.r_0[1]."""
    return _SUBSCRIPT.sub(lambda m: f"[{int(m.group(1)) + 1}]", name)


def fmi_variables(meta: dict, fmi: int) -> list:
    """Every FMU variable: name (FMI), vr, causality, variability, initial, start, unit, and what the
    wrapper does with it: get (0 observed, 1 derivative, 2 event indicator; index), set (1 start value,
    2 input, 3 parameter, 4 mode; index), known (1 state, 2 input, 3 parameter; index)."""
    x = {v["name"]: k for k, v in enumerate(meta["x"])}
    z = {v["name"] for v in meta["z"]}
    u = {v["name"]: k for k, v in enumerate(meta["u"])}
    p = {v["name"]: k for k, v in enumerate(meta["p"])}
    d = {v["name"]: k for k, v in enumerate(meta["d"])}
    starts = {s["name"]: k for k, s in enumerate(meta["starts"])}
    out = []
    for k, v in enumerate(meta["observed"]):
        name = v["name"]
        var = {"name": fmi_name(name), "mechnet": name, "vr": k + 1, "unit": v["unit"], "get": (0, k),
               "causality": "output" if v["kind"] == "output" else "local", "variability": "continuous",
               "initial": "calculated"}
        if name in u:
            var.update(causality="input", initial=None, start=meta["u"][u[name]]["default"], set=(2, u[name]),
                       known=(2, u[name]))
        elif name in p:
            var.update(causality="parameter", variability="tunable", initial="exact",
                       start=meta["p"][p[name]]["value"], set=(3, p[name]), known=(3, p[name]))
        elif name in d:
            var.update(variability="discrete", initial="exact", start=meta["d"][d[name]]["start"], set=(4, d[name]))
        elif name in starts:
            var.update(initial="exact", start=meta["starts"][starts[name]]["value"], set=(1, starts[name]))
        if name in x:
            var.update(known=(1, x[name]), nominal=meta["x"][x[name]]["nominal"])
        var["state"] = name in x
        var["algebraic"] = name in z
        out.append(var)
    by_name = {v["mechnet"]: v for v in out}
    for k, state in enumerate(meta["x"]):
        der = f"der({state['name']})"
        state_vr = by_name[state["name"]]["vr"]
        if der in by_name:
            by_name[der].update(get=(1, k), derivative=state_vr)
        else:
            out.append({"name": fmi_name(der), "mechnet": der, "vr": len(out) + 1, "unit": f"({state['unit']})/s",
                        "get": (1, k), "causality": "local", "variability": "continuous", "initial": "calculated",
                        "derivative": state_vr})
    if fmi == 3:
        for k, event in enumerate(meta["zero"]):
            out.append({"name": f"_event_indicator[{k + 1}]", "mechnet": None, "vr": len(out) + 1, "unit": "1",
                        "get": (2, k), "causality": "local", "variability": "continuous", "initial": "calculated",
                        "description": event["label"]})
    return out


def _rows(pattern: list, n_rows: int) -> list:
    rows = [[] for _ in range(n_rows)]
    for r, c in pattern:
        rows[r].append(c)
    return rows


def model_structure(meta: dict, variables: list) -> dict:
    """{"outputs", "derivatives", "initial": [(vr, [known vr, ...]), ...]}, each sorted by vr."""
    deps = meta["dependencies"]
    n_y, n_x = len(meta["observed"]), len(meta["x"])
    observed_vr = [v["vr"] for v in variables[:n_y]]
    by_name = {v["mechnet"]: v for v in variables}
    x_vr = [by_name[v["name"]]["vr"] for v in meta["x"]]
    u_vr = [by_name[v["name"]]["vr"] for v in meta["u"]]
    p_vr = [by_name[v["name"]]["vr"] for v in meta["p"]]
    s_vr = [by_name[s["name"]]["vr"] for s in meta["starts"]]
    d_vr = [by_name[v["name"]]["vr"] for v in meta["d"]]

    def knowns(rows_by_kind, row):
        found = set()
        for rows, vrs in rows_by_kind:
            found.update(vrs[c] for c in rows[row])
        return sorted(found)

    y_rows = [(_rows(deps["y_x"], n_y), x_vr), (_rows(deps["y_u"], n_y), u_vr)]
    xdot_rows = [(_rows(deps["xdot_x"], n_x), x_vr), (_rows(deps["xdot_u"], n_x), u_vr)]
    outputs = [(v["vr"], knowns(y_rows, v["get"][1])) for v in variables if v["causality"] == "output"]
    der_vars = {v["get"][1]: v for v in variables if "derivative" in v}
    derivatives = [(der_vars[k]["vr"], knowns(xdot_rows, k)) for k in range(n_x)]

    def init_rows(what, n):
        return [(_rows(deps[f"init_{what}_s"], n), s_vr), (_rows(deps[f"init_{what}_u"], n), u_vr),
                (_rows(deps[f"init_{what}_p"], n), p_vr), (_rows(deps[f"init_{what}_d"], n), d_vr)]

    init_y, init_xdot = init_rows("y", n_y), init_rows("xdot", n_x)
    initial = []
    state_vrs = set(x_vr)
    for v in variables:
        if v.get("initial") not in ("calculated", "approx"):
            continue
        if v["causality"] == "output" or "derivative" in v or v["vr"] in state_vrs:
            kind, k = v["get"]
            initial.append((v["vr"], knowns(init_xdot if kind == 1 else init_y, k)))
    del observed_vr
    return {"outputs": sorted(outputs), "derivatives": derivatives, "initial": sorted(initial)}


def _attrs(**kw) -> str:
    return "".join(f" {k}={quoteattr(str(v))}" for k, v in kw.items() if v is not None)


def _number(value: float) -> str:
    return repr(float(value))


LOG_CATEGORIES = (("logEvents", "each event: its time and the condition that fired"),
                  ("logStatusError", "why a call returned an error"))


def model_description(meta: dict, variables: list, ident: str, fmi: int, sources: list) -> str:
    names = [v["name"] for v in variables]
    convention = "structured" if all(STRUCTURED.match(n) for n in names) else "flat"
    units = sorted({v["unit"] for v in variables})
    structure = model_structure(meta, variables)
    head = _attrs(fmiVersion=f"{fmi}.0", modelName=meta["name"],
                  description=f"{meta['name']}: exported by mechnet (Model Exchange)",
                  **({"guid": meta["guid"]} if fmi == 2 else {"instantiationToken": meta["guid"]}),
                  generationTool="mechnet", variableNamingConvention=convention,
                  **({"numberOfEventIndicators": len(meta["zero"])} if fmi == 2 else {}))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', f"<fmiModelDescription{head}>"]
    if fmi == 2:
        lines += [f'  <ModelExchange{_attrs(modelIdentifier=ident, canGetAndSetFMUstate="false", providesDirectionalDerivative="true")}>',
                  "    <SourceFiles>", *[f"      <File{_attrs(name=s)}/>" for s in sources], "    </SourceFiles>",
                  "  </ModelExchange>"]
    else:
        lines += [f'  <ModelExchange{_attrs(modelIdentifier=ident, canGetAndSetFMUState="false", providesDirectionalDerivatives="true", needsCompletedIntegratorStep="true")}/>']
    lines += ["  <UnitDefinitions>", *[f"    <Unit{_attrs(name=u)}/>" for u in units], "  </UnitDefinitions>"]
    lines += ["  <LogCategories>", *[f"    <Category{_attrs(name=n, description=d)}/>" for n, d in LOG_CATEGORIES],
              "  </LogCategories>"]
    lines += ["  <ModelVariables>"]
    if fmi == 3:
        lines.append('    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>')
    for v in variables:
        common = dict(name=v["name"], valueReference=v["vr"], description=v.get("description"),
                      causality=v["causality"], variability=v["variability"], initial=v.get("initial"))
        typed = dict(unit=v["unit"], nominal=_number(v["nominal"]) if "nominal" in v else None,
                     start=_number(v["start"]) if v.get("start") is not None else None,
                     derivative=v.get("derivative"))
        if fmi == 2:
            lines.append(f"    <ScalarVariable{_attrs(**common)}><Real{_attrs(**typed)}/></ScalarVariable>")
        else:
            lines.append(f"    <Float64{_attrs(**common, **typed)}/>")
    lines += ["  </ModelVariables>", "  <ModelStructure>"]

    def unknown(tag, vr, deps):
        key = "index" if fmi == 2 else "valueReference"
        return f"    <{tag}{_attrs(**{key: vr}, dependencies=' '.join(map(str, deps)))}/>" if deps else \
            f'    <{tag}{_attrs(**{key: vr}, dependencies="")}/>'

    if fmi == 2:
        for title, key in (("Outputs", "outputs"), ("Derivatives", "derivatives"), ("InitialUnknowns", "initial")):
            if structure[key]:
                lines += [f"    <{title}>", *["  " + unknown("Unknown", vr, deps) for vr, deps in structure[key]],
                          f"    </{title}>"]
    else:
        lines += [unknown("Output", vr, deps) for vr, deps in structure["outputs"]]
        lines += [unknown("ContinuousStateDerivative", vr, deps) for vr, deps in structure["derivatives"]]
        lines += [unknown("InitialUnknown", vr, deps) for vr, deps in structure["initial"]]
        lines += [f"    <EventIndicator{_attrs(valueReference=v['vr'])}/>" for v in variables if v["get"][0] == 2]
    lines += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)
