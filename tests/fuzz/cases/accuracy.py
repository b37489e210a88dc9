"""Accuracy studies (mechnet.accuracy.study): methods, tolerances, step counts, times and references.
Each study is kept to one or two cheap runs."""
from __future__ import annotations

import math

from mechnet.accuracy import study
from fuzz import fixtures
from fuzz.framework import Collector, expect

NEEDS = ("osc",)
SMALL = {"methods": ["cvodes-adams"], "tolerances": (1e-4,), "steps": (10,), "repeat": 1, "workers": 0}


def _study(**kw):
    t_end = kw.pop("t_end", 0.2)
    return lambda: study(fixtures.osc(), t_end, **{**SMALL, **kw})


def collector() -> Collector:
    col = Collector("accuracy")
    bad = {
        "t_end.zero": ({"t_end": 0.0}, "t_end"), "t_end.nan": ({"t_end": math.nan}, "t_end"),
        "t_end.text": ({"t_end": "1"}, "t_end"), "at.past_end": ({"at": 1.0}, "at"),
        "at.negative": ({"at": -0.1}, "at"),
        "at.nan": ({"at": math.nan}, "at"), "methods.unknown": ({"methods": ["rk45"]}, "rk45"),
        "methods.number": ({"methods": 3}, "methods"),
        "methods.empty": ({"methods": []}, "methods"), "tolerances.negative": ({"tolerances": (-1e-3,)}, "tolerances"),
        "tolerances.nan": ({"tolerances": (math.nan,)}, "tolerances"),
        "tolerances.text": ({"tolerances": "1e-3"}, "tolerances"),
        "tolerances.empty": ({"tolerances": ()}, "tolerances"), "steps.zero": ({"steps": (0,),
        "methods": ["rk"]}, "steps"),
        "steps.float": ({"steps": (2.5,), "methods": ["rk"]}, "steps"),
        "names.unknown": ({"names": ["j9.phi"]}, "j9.phi"),
        "repeat.zero": ({"repeat": 0}, "repeat"), "workers.negative": ({"workers": -1}, "workers"),
        "reference.not_callable": ({"reference": 3.0}, "reference"),
        "reference.raises": ({"reference": lambda t: 1 / 0}, "reference"),
        "reference.unknown_name": ({"reference": lambda t: {"j9.phi": 0.0 * t}}, "j9.phi"),
        "reference.text": ({"reference": lambda t: "x"}, "reference"),
        "client.text": ({"client": "tcp://nowhere:1"}, "client"),
    }
    for what, (kw, culprit) in bad.items():
        col.bad(what, _study(**kw), (culprit,), needs=NEEDS,
                known="a reference(t) that raises" if what == "reference.raises" else "")
    col.bad("not_compiled", lambda: study(fixtures.osc, 0.2), ("study",), needs=NEEDS)
    col.bad("recommend.target_nan", lambda: _study()().recommend(math.nan), ("error",), needs=NEEDS)
    col.bad("recommend.target_negative", lambda: _study()().recommend(-1e-6), ("error",), needs=NEEDS)
    col.good("exact_reference", _study(reference=lambda t: {"j1.phi": 0.5 * __import__("numpy").cos(
        math.sqrt(1000.0) * t)}, tolerances=(1e-6,)), "the oscillator against its closed form",
        lambda st: expect(0 < min(tr.error for tr in st.trials) < 1e-4, "a small error"),
        needs=NEEDS)
    col.good("reference.nan", _study(reference=lambda t: {"j1.phi": math.nan + 0 * t}),
             "NaN is a closed form that has no value there (it ends earlier): the study says so and measures "
             "against its own tight runs",
             lambda st: expect(any("reference(t) gives no value" in w for w in st.warnings)
                               and all(math.isfinite(tr.error) for tr in st.trials), "noted, finite errors"),
             needs=NEEDS)
    return col
