"""Exports and loads: cm.export's kind, version and path, and mechnet.export.load of a folder someone
changed (model.json's format, names, files; a .casadi file cut short)."""
from __future__ import annotations

import json
import math
import os
import shutil

from fuzz import fixtures
from fuzz.framework import Collector, close, expect

NEEDS = ("driven",)


def _export(path, **kw):
    return lambda: fixtures.driven().export(path, **kw)


def _tampered(change):
    """Load a copy of the driven model's export after `change(record, folder)` (record: model.json)."""
    def run():
        from mechnet.export import load
        folder = shutil.copytree(fixtures.casadi_export(), "copy")
        path = os.path.join(folder, "model.json")
        with open(path) as f:
            record = json.load(f)
        if change(record, folder) != "raw":           # "raw": the change wrote model.json itself
            with open(path, "w") as f:
                json.dump(record, f)
        return load(folder).simulate(0.5, n_out=3, inputs={"drive.tau": 1.0})
    return run


def _set(key, value):
    def change(record, folder):
        record[key] = value
    return change


def _drop(key):
    return lambda record, folder: record.pop(key)


def _edit_first(key, field, value):
    def change(record, folder):
        record[key][0][field] = value
    return change


def _file(name, data):
    def change(record, folder):
        with open(os.path.join(folder, name), "w" if isinstance(data, str) else "wb") as f:
            f.write(data)
        return "raw" if name == "model.json" else None
    return change


def collector() -> Collector:
    col = Collector("export")
    for what, kind in (("unknown", "zip"), ("case", "FMU"), ("none", None), ("number", 2)):
        col.bad(f"kind.{what}", _export("out", kind=kind), ("kind",), needs=NEEDS)
    for what, fmi in (("one", 1), ("text", "2"), ("float", 2.5), ("none", None)):
        col.bad(f"fmi.{what}", _export("out.fmu", kind="fmu", fmi=fmi), ("fmi",), needs=NEEDS)
    col.bad("path.under_file", lambda: (open("f", "w").close(), fixtures.driven().export("f/out", kind="casadi")),
            ("f/out",), needs=NEEDS, known="an export path under a file")
    col.bad("path.empty", _export(""), ("path",), needs=NEEDS)
    col.bad("path.none", _export(None), ("path",), needs=NEEDS)
    col.bad("path.number", _export(3), ("path",), needs=NEEDS)
    col.bad("path.cwd", _export(".", overwrite=True), (".",), needs=NEEDS)
    col.bad("path.existing_folder", lambda: (os.mkdir("mine"), open("mine/notes.txt", "w").close(),
                                              fixtures.driven().export("mine", overwrite=True)), ("mine",), needs=NEEDS)
    col.bad("path.existing_no_overwrite", lambda: (fixtures.driven().export("e1"), fixtures.driven().export("e1")),
            ("e1",), needs=NEEDS)
    col.bad("path.fmu_suffix", _export("out.zip", kind="fmu"), ("out.zip",), needs=NEEDS)
    col.bad("overwrite.text", _export("out", overwrite="yes"), ("overwrite",), needs=NEEDS)
    col.good("path.overwrite_own",
             lambda: (fixtures.driven().export("e2"), fixtures.driven().export("e2", overwrite=True)),
             "a previous mechnet export is replaced with overwrite=True",
             lambda v: expect(os.path.isfile("e2/model.json"), "written"), needs=NEEDS)
    col.good("path.pathlike", lambda: fixtures.driven().export(__import__("pathlib").Path("p1")),
             "a pathlib.Path is a path", lambda v: expect(os.path.isfile("p1/model.json"), "written"), needs=NEEDS)
    exact = lambda res: expect(close(res["j1.phi"][-1], 0.01 * (1 - math.cos(math.sqrt(1000.0) * 0.5)), 1e-4),
                               "the loaded copy simulates as the model")  # noqa: E731
    # loads of tampered folders
    load_needs = ("driven", "casadi_export")
    tampering = {
        "format.missing": (_drop("format"), "format"), "format.text": (_set("format", "1"), "format"),
        "format.newer": (_set("format", 99), "format"), "format.null": (_set("format", None), "format"),
        "format.float": (_set("format", 1.5), "format"),
        "json.invalid": (_file("model.json", "{not json"), "model.json"), "json.list": (None, "model.json"),
        "files.missing": (_drop("files"), "files"), "x.missing": (_drop("x"), "x"),
        "x.name_number": (_edit_first("x", "name", 3), "x"), "x.nominal_nan": (_edit_first("x", "nominal", "NaN"),
        "nominal"),
        "x.nominal_negative": (_edit_first("x", "nominal", -1.0), "nominal"),
        "p.value_nan": (_edit_first("p", "value", "NaN"), ("spring.c", "p[0]")),
        "p.value_negative": (_edit_first("p", "value", -5.0), ("spring.c", "p[0]")),
        "p.check_unknown": (_edit_first("p", "check", "os.system"), "os.system"),
        "starts.unknown": (_edit_first("starts", "name", "j9.phi"), "j9.phi"),
        "starts.value_text": (_edit_first("starts", "value", "zero"), ("j1.phi", "starts[0]")),
        "u.default_text": (_edit_first("u", "default", "x"), ("drive.tau", "u[0]")),
        "casadi.truncated": (_file("ode.casadi", "casadi garbage"), "ode.casadi"),
        "casadi.removed": (lambda r, folder: os.remove(os.path.join(folder, "ode.casadi")), "ode.casadi"),
        "casadi.swapped": (lambda r, folder: shutil.copy(os.path.join(folder, "alg.casadi"),
                                                         os.path.join(folder, "ode.casadi")), "ode"),
        "files.outside": (lambda r, folder: r["files"].__setitem__("ode", "../../etc/passwd"), "ode"),
        "kind.unknown": (_set("kind", "zip"), "kind"), "sha.changed": (None, "ode"),
    }
    for what, (change, culprit) in tampering.items():
        if what == "json.list":
            change = _file("model.json", "[1, 2]")
        if what == "sha.changed":
            def change(record, folder):
                record["sha256"]["ode.casadi"] = "0" * 64
        col.bad(f"load.{what}", _tampered(change), (culprit,),
                needs=load_needs,
                known='"written by a newer mechnet" for a missing or string format'
                if what in ("format.missing", "format.text") else "")
    col.good("load.untouched", _tampered(lambda r, f: None), "an export loads back", exact, needs=load_needs)
    col.good("load.extra_key", _tampered(_set("comment", "mine")), "an unknown key is extra information",
             exact, needs=load_needs)
    from mechnet.export import load
    col.bad("load.missing_folder", lambda: load("nothing_here"), ("nothing_here",))
    col.bad("load.a_file", lambda: (open("x.txt", "w").close(), load("x.txt")), ("x.txt",))
    col.bad("load.none", lambda: load(None), ("path",))
    col.bad("load.empty_folder", lambda: (os.mkdir("empty"), load("empty")), ("empty",))
    col.bad("loaded.simulate.unknown_input", lambda: load(fixtures.casadi_export()).simulate(
        0.5, inputs={"drive.f": 1.0}), ("drive.f",), needs=load_needs)
    col.bad("loaded.simulate.params_nan", lambda: load(fixtures.casadi_export()).simulate(
        0.5, params={"spring.c": math.nan}), ("spring.c",), needs=load_needs)
    col.bad("loaded.simulate.params_negative", lambda: load(fixtures.casadi_export()).simulate(
        0.5, params={"spring.c": -1.0}), ("spring.c",), needs=load_needs)
    col.bad("loaded.simulate.unknown_keyword", lambda: load(fixtures.casadi_export()).simulate(0.5, rtoll=1e-3),
            ("rtoll",), needs=load_needs)
    return col
