"""Every public entry point, walked with the same wrong-type arguments (issue 16's "done when"): None, a
string, a list, NaN and a bool each raise a MechnetError naming the argument, or are accepted where the
value means something (None: the default; a string where a name or a path is asked for; True where a flag
is). Nothing escapes as a bare TypeError/ValueError/AttributeError."""
from __future__ import annotations

import math
import warnings

import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from models import oscillator

BAD = {"None": None, "string": "abc", "list": [1, 2], "nan": math.nan, "bool": True}

# the values each entry point may take: None where it means the default, and the like
MEANINGFUL = {
    "simulate(t_start)": {"None"}, "simulate(n_out)": {"None"}, "simulate(t_out)": {"None"}, "simulate(params)": {"None"},
    "simulate(inputs)": {"None"}, "simulate(start)": {"None"}, "simulate(guess)": {"None"},
    "simulate(progress)": {"None", "bool"}, "simulate(continue_from)": {"None"},
    "linearize(x_op)": {"None"}, "linearize(u_op)": {"None"}, "trim(inputs)": {"None"}, "trim(fixed)": {"None"},
    "Result.plot(names)": {"None"}, "Result.to_csv(path)": {"string"}, "Model(name)": {"string"},
    "Inertia(name)": {"string"}, "Inertia(phi_start)": {"None"}, "compile(options)": {"None"},
}


@pytest.fixture(scope="module")
def cm():
    return oscillator().compile()


def _entry_points(cm, res):
    return {
        "simulate(t_end)": lambda v: cm.simulate(v),
        "simulate(t_start)": lambda v: cm.simulate(1.0, t_start=v),
        "simulate(rtol)": lambda v: cm.simulate(1.0, rtol=v),
        "simulate(atol)": lambda v: cm.simulate(1.0, atol=v),
        "simulate(n_out)": lambda v: cm.simulate(1.0, n_out=v),
        "simulate(t_out)": lambda v: cm.simulate(1.0, t_out=v),
        "simulate(method)": lambda v: cm.simulate(1.0, method=v),
        "simulate(params)": lambda v: cm.simulate(1.0, params=v),
        "simulate(inputs)": lambda v: cm.simulate(1.0, inputs=v),
        "simulate(start)": lambda v: cm.simulate(1.0, start=v),
        "simulate(guess)": lambda v: cm.simulate(1.0, guess=v),
        "simulate(max_steps)": lambda v: cm.simulate(1.0, max_steps=v),
        "simulate(progress)": lambda v: cm.simulate(1.0, progress=v),
        "simulate(steady_state)": lambda v: cm.simulate(1.0, steady_state=v),
        "simulate(continue_from)": lambda v: cm.simulate(1.0, continue_from=v),
        "linearize(x_op)": lambda v: cm.linearize(x_op=v),
        "linearize(u_op)": lambda v: cm.linearize(u_op=v),
        "trim(inputs)": lambda v: cm.trim(inputs=v),
        "trim(fixed)": lambda v: cm.trim(fixed=v),
        "kinematics(q)": lambda v: mn.kinematics(cm, q=v),
        "Result[name]": lambda v: res[v],
        "Result.plot(names)": lambda v: res.plot(v),
        "Result.to_csv(path)": lambda v: res.to_csv(v),
        "Model(name)": lambda v: mn.Model(v),
        "Model.add(component)": lambda v: mn.Model("m").add(v),
        "Model.connect(a, b)": lambda v: mn.Model("m").connect(v, v),
        "Inertia(J)": lambda v: rot.Inertia(name="j", J=v),
        "Inertia(name)": lambda v: rot.Inertia(name=v, J=1.0),
        "Inertia(phi_start)": lambda v: rot.Inertia(name="j", J=1.0, phi_start=v),
        "Spring(c)": lambda v: rot.Spring(name="s", c=v),
        "compile(options)": lambda v: oscillator().compile(v),
    }


def test_every_entry_point_names_its_wrong_arguments(cm, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                      # to_csv('abc') writes a file here
    res = cm.simulate(0.5, n_out=11)
    escaped = []
    for entry, call in _entry_points(cm, res).items():
        for kind, value in BAD.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    call(value)
                except mn.MechnetError:
                    continue
                except Exception as exc:          # noqa: BLE001 - collected and reported below
                    escaped.append(f"{entry} with {kind}: {type(exc).__name__}: {exc}"[:160])
                    continue
            if kind not in MEANINGFUL.get(entry, set()):
                escaped.append(f"{entry} with {kind}: accepted")
    assert not escaped, "\n".join(escaped)
