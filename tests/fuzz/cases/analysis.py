"""Analysis of a compiled model and its results: linearize, trim, kinematics, functions, the Result's
indexing, tables, CSV and plots, and mechnet.inertia's shape tables."""
from __future__ import annotations

import math

import numpy as np

import mechnet as mn
from mechnet import inertia
from fuzz import fixtures
from fuzz.framework import Collector, close, expect


def _res():
    return fixtures.osc().simulate(0.5, n_out=11)


def collector() -> Collector:
    col = Collector("analysis")
    osc, pend = ("osc",), ("pendulum",)
    for what, q, culprit in (("list", [1, 2, 3], "q"), ("unknown", {"rev.psi": 1.0}, "rev.psi"),
                             ("nan", {"rev.phi": math.nan}, "rev.phi"), ("text", {"rev.phi": "a"}, "rev.phi"),
                             ("vector", {"rev.phi": [1.0, 2.0]}, "rev.phi"), ("number", 1.0, "q"),
                             ("not_coordinate", {"bob.frame_a.r_0[0]": 1.0}, "bob.frame_a.r_0[0]")):
        col.bad(f"kinematics.q.{what}", lambda q=q: mn.kinematics(fixtures.pendulum(), q=q), (culprit,), needs=pend,
                known="kinematics(cm, q=[1, 2, 3])" if what == "list" else "")
    col.bad("kinematics.qd.list", lambda: mn.kinematics(fixtures.pendulum(), qd=[1.0]), ("qd",), needs=pend)
    col.bad("kinematics.params.unknown", lambda: mn.kinematics(fixtures.pendulum(), params={"rod.r": 1.0}),
            ("rod.r",), needs=pend)
    col.bad("kinematics.not_compiled", lambda: mn.kinematics("pendulum"), ("kinematics",))
    col.bad("linearize.x_op.list_short", lambda: fixtures.osc().linearize(x_op=[0.1]), ("x_op",), needs=osc)
    col.bad("linearize.x_op.unknown", lambda: fixtures.osc().linearize(x_op={"j1.psi": 0.1}), ("j1.psi",), needs=osc)
    col.bad("linearize.x_op.nan", lambda: fixtures.osc().linearize(x_op={"j1.phi": math.nan}), ("j1.phi",), needs=osc)
    col.bad("linearize.u_op.unknown", lambda: fixtures.driven().linearize(u_op={"drive.f": 0.0}), ("drive.f",),
            needs=("driven",))
    col.bad("linearize.outputs.unknown", lambda: fixtures.osc().linearize(outputs=["j1.psi"]), ("j1.psi",), needs=osc)
    col.bad("linearize.t.text", lambda: fixtures.osc().linearize(t="0"), ("t",), needs=osc)
    col.bad("linearize.unknown_keyword", lambda: fixtures.osc().linearize(x0={"j1.phi": 0.0}), ("x0",), needs=osc)
    col.good("linearize.oscillator", lambda: fixtures.osc().linearize(), "the oscillator about rest",
             lambda lin: expect(close(sorted(np.linalg.eigvals(lin.A).imag), [-math.sqrt(1000), math.sqrt(1000)]),
                                "eigenvalues ±j sqrt(1000)"), needs=osc)
    col.bad("trim.fixed.unknown", lambda: fixtures.osc().trim(fixed={"j1.psi": 0.0}), ("j1.psi",), needs=osc)
    col.bad("trim.free_inputs.unknown", lambda: fixtures.driven().trim(free_inputs=["drive.f"]), ("drive.f",),
            needs=("driven",))
    col.bad("trim.max_iter.zero", lambda: fixtures.osc().trim(max_iter=0), ("max_iter",), needs=osc)
    col.bad("trim.inputs.nan", lambda: fixtures.driven().trim(inputs={"drive.tau": math.nan}), ("drive.tau",),
            needs=("driven",))
    col.bad("trim.impossible", lambda: fixtures.driven().trim(fixed={"j1.phi": 1.0}), ("j1.phi",), needs=("driven",))
    col.good("trim.driven", lambda: fixtures.driven().trim(fixed={"j1.phi": 0.5}, free_inputs=["drive.tau"]),
             "the torque that holds j1 at 0.5 rad is c·0.5", lambda tp: expect(
                 close(tp.u["drive.tau"], 50.0), "50 N·m"),
             needs=("driven",))
    # results
    col.bad("result.unknown_name", lambda: _res()["j1.psi"], ("j1.psi",), needs=osc)
    col.bad("result.index_number", lambda: _res()[0], ("0",), needs=osc)
    col.bad("result.plot.unknown", lambda: _res().plot(["j1.phi", "j9.w"]), ("j9.w",), needs=osc)
    col.bad("result.plot.number", lambda: _res().plot(3), ("names",), needs=osc)
    col.good("result.plot.one_name", lambda: _res().plot("j1.phi"), "one name is one name (issue 32)",
             lambda fig: expect(len(fig.axes) == 1, "one subplot"), needs=osc)
    col.bad("result.plot.reference_unknown", lambda: _res().plot(["j1.phi"], reference={"j9.phi": lambda t: t}),
            ("j9.phi",), needs=osc)
    col.bad("result.to_csv.directory", lambda: _res().to_csv("."), ("path",), needs=osc)
    col.bad("result.to_csv.missing_folder", lambda: _res().to_csv("no/such/out.csv"), ("no/such",), needs=osc)
    col.bad("result.to_csv.names_unknown", lambda: _res().to_csv("out.csv", names=["j9"]), ("j9",), needs=osc)
    col.bad("result.to_csv.under_file", lambda: (open("f", "w").close(), _res().to_csv("f/out.csv")), ("f",),
            needs=osc)
    col.bad("result.to_pandas.unknown", lambda: _res().to_pandas(["j9"]), ("j9",), needs=osc)
    col.bad("functions.unknown_key", lambda: fixtures.osc().functions()["odee"], ("odee",), needs=osc)

    def csv_quotes():
        import csv
        m = mn.Model("q")
        from models import oscillator
        res = oscillator().compile().simulate(0.1, n_out=3)
        res.title = 'say "hi"'
        res.to_csv("out.csv")
        with open("out.csv") as f:
            rows = list(csv.reader(f))
        return rows
    col.good("result.to_csv.readable", csv_quotes, "the CSV parses back with the csv module",
             lambda rows: expect(len(rows) >= 4 and all(len(r) == len(rows[0]) for r in rows[1:]), "rectangular"))
    # inertia tables
    for what, make, culprit in (
            ("rod.negative_mass", lambda: inertia.rod(-1.0, 1.0), "m"),
            ("disc.nan", lambda: inertia.disc(1.0, math.nan), "radius"),
            ("box.text", lambda: inertia.box(1.0, "a", 1, 1), "a"),
            ("rod.axis", lambda: inertia.rod(1.0, 1.0, axis=3), "axis"),
            ("hollow.inside_out", lambda: inertia.hollow_cylinder(1.0, 2.0, 1.0, 1.0), "inner"),
            ("transfer.short", lambda: inertia.transfer(np.eye(3), 1.0, [1, 0]), "d"),
            ("rotate.not_rotation", lambda: inertia.rotate(np.eye(3), 2 * np.eye(3)), "R"),
            ("principal.nan", lambda: inertia.principal_axes(np.full((3, 3), math.nan)), "I"),
            ("sphere.zero", lambda: inertia.sphere(0.0, 1.0), "m"),
            ("composite.text", lambda: inertia.composite("ab"), "parts")):
        col.bad(f"inertia.{what}", make, (culprit,))
    col.good("inertia.rod", lambda: inertia.rod(3.0, 2.0), "m L^2 / 12 across the rod",
             lambda I: expect(close(np.diag(I), [0.0, 1.0, 1.0]), "diag(0, 1, 1)"))
    return col
