"""The `mechnet` command: each subcommand with bad options and bad scene files, run in the case's own
process through `mechnet.cli.main` (an `error: ...` line and status 2 is a refusal; see framework.cli)."""
from __future__ import annotations

import os

from fuzz.framework import Collector, cli, expect
from fuzz.fixtures import SCENE, scene


def _sim(*args, text=SCENE, extra=""):
    return lambda: cli("simulate", scene(text, extra=extra), *args)


def collector() -> Collector:
    col = Collector("cli")
    for what, args, culprit in (
            ("t_end.text", ("--t-end", "abc"), "--t-end"), ("t_end.zero", ("--t-end", "0"), "t_end"),
            ("t_end.nan", ("--t-end", "nan"), "t_end"), ("t_end.negative", ("--t-end", "-1"), "t_end"),
            ("rtol.negative", ("--rtol", "-1"), "rtol"), ("rtol.nan", ("--rtol", "nan"), "rtol"),
            ("atol.zero", ("--atol", "0"), "atol"), ("method.unknown", ("--method", "rk45"), "--method"),
            ("n_out.one", ("--n-out", "1"), "n_out"), ("n_out.float", ("--n-out", "2.5"), "--n-out"),
            ("plot.directory", ("--plot", "."), "--plot"), ("csv.directory", ("--csv", "."), "--csv"),
            ("csv.under_file", ("--csv", "scene.py/out.csv"), "--csv"), ("unknown_option", ("--speed", "2"),
            "--speed")):
        col.bad(f"simulate.{what}", _sim(*args), (culprit,))
    col.bad("simulate.missing_file", lambda: cli("simulate", "nothing.py"), ("nothing.py",))
    col.bad("simulate.not_python", lambda: cli("simulate", scene("this is not python\n")), ("scene.py",))
    col.bad("simulate.no_build", lambda: cli("simulate", scene("t_end = 1\n")), ("build",))
    col.bad("simulate.build_raises", lambda: cli("simulate", scene("def build():\n    raise ValueError('boom')\n")),
            ("scene.py",))
    col.bad("simulate.build_returns_none", lambda: cli("simulate", scene("def build():\n    return None\n")),
            ("build",))
    col.bad("simulate.build_exits", lambda: cli("simulate", scene("import sys\ndef build():\n    sys.exit(3)\n")),
            ("scene.py",))
    col.bad("simulate.plot_typo", _sim(extra='\nplot = ["j1.phy"]\n'), ("j1.phy",))
    col.bad("simulate.t_end_text", _sim(extra='\nt_end = "long"\n'), ("t_end",))
    col.bad("simulate.reference_raises", _sim(extra="\ndef reference(t):\n    raise ValueError('no')\n"),
            ("reference",), known="a reference(t) that raises")
    col.bad("simulate.reference_unknown", _sim(extra="\ndef reference(t):\n    return {'j9.phi': t}\n"), ("j9.phi",))
    col.bad("simulate.directory_as_file", lambda: (os.mkdir("d"), cli("simulate", "d"))[1], ("d",))
    col.good("simulate.ok", _sim("--t-end", "0.5", "--n-out", "11", "--csv", "out.csv"),
             "the good scene runs", lambda out: expect(os.path.isfile("out.csv"), "CSV written"))
    # export
    col.bad("export.kind", lambda: cli("export", scene(), "--kind", "zip", "-o", "out"), ("--kind",))
    col.bad("export.fmi", lambda: cli("export", scene(), "--kind", "fmu", "--fmi", "4", "-o", "o.fmu"), ("--fmi",))
    col.bad("export.no_out", lambda: cli("export", scene(), "--kind", "casadi"), (("-o", "--out"),))
    col.bad("export.under_file", lambda: cli("export", scene(), "--kind", "casadi", "-o", "scene.py/out"),
            ("scene.py/out",))
    col.bad("export.existing", lambda: (os.mkdir("o"), open("o/x", "w").close(),
                                        cli("export", scene(),
                                        "--kind", "casadi", "-o", "o", "--overwrite"))[2], ("o",))
    # accuracy
    acc = ("--methods", "cvodes-adams", "--tolerances", "1e-3")
    col.bad("accuracy.out_file", lambda: cli("accuracy", scene(), *acc, "-o", "scene.py"), ("scene.py",),
            known="accuracy -o <existing file>")
    col.bad("accuracy.target_nan", lambda: cli("accuracy", scene(), *acc, "--target", "nan"), ("target",),
            known="--target nan")
    col.bad("accuracy.target_negative", lambda: cli("accuracy", scene(), *acc, "--target", "-1"), ("target",))
    col.bad("accuracy.at_past", lambda: cli("accuracy", scene(), *acc, "--at", "5", "--t-end", "1"), ("at",))
    col.bad("accuracy.method", lambda: cli("accuracy", scene(), "--methods", "rk45"), ("rk45",))
    col.bad("accuracy.tolerance_text", lambda: cli("accuracy", scene(), "--tolerances", "fine"), ("--tolerances",))
    col.bad("accuracy.workers_negative", lambda: cli("accuracy", scene(), *acc, "--workers", "-3"), ("workers",))
    col.bad("accuracy.scheduler", lambda: cli("accuracy", scene(), *acc, "--scheduler", "tcp://127.0.0.1:1"),
            ("scheduler",), slow=True)
    # demo
    col.bad("demo.only_unknown", lambda: cli("demo", "--only", "nothing", "--out", "plots"), ("nothing",))
    col.bad("demo.dir_missing", lambda: cli("demo", "--dir", "nowhere", "--out", "plots"), ("nowhere",))
    col.bad("demo.out_file", lambda: (open("plots", "w").close(), cli("demo", "--only", "two_inertia_oscillator",
                                                                      "--out", "plots"))[1], ("plots",))
    col.bad("command.unknown", lambda: cli("simulat", "x.py"), ("simulat",))
    col.bad("command.none", lambda: cli(), (("command", "COMMAND"),))
    col.good("version", lambda: cli("--version"), "prints the version", lambda out: expect("mechnet" in out, "named"))
    return col
