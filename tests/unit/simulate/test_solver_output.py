"""SUNDIALS's messages stay with the run that caused them (`mechnet/solver_output.py`): none reach stderr,
and a run in another thread at the same time keeps a record of its own."""
from __future__ import annotations

import threading

import numpy as np

import mechnet as mn
from models import oscillator


class Loop(mn.Component):
    """z + z³ = x, x' = −z: a DAE (IDAS), which with a budget of 3 steps prints "mxstep steps taken"."""

    x = mn.State()
    z = mn.Var()

    def equations(self):
        return [mn.Eq(self.z + self.z ** 3, self.x, "nonlinear loop"), mn.Eq(mn.der(self.x), -self.z, "decay")]


def _starved():
    m = mn.Model("starved")
    m.add(Loop(name="l", x_start=1.0))
    return m.compile()


def test_each_thread_keeps_its_own_solver_messages(capfd, recwarn):
    failing, quiet = _starved(), oscillator().compile()
    out = {}

    def run(key, cm, **kw):
        out[key] = [cm.simulate(2.0, rtol=1e-8, atol=1e-10, **kw) for _ in range(5)]

    threads = [threading.Thread(target=run, args=("failing", failing), kwargs={"max_steps": 3}),
               threading.Thread(target=run, args=("quiet", quiet))]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for res in out["failing"]:
        assert not res.success
        # what was computed holds: the start x = 1 and z + z³ = x at every kept point (Newton accuracy)
        assert res["l.x"][0] == 1.0
        assert np.allclose(res["l.z"] + res["l.z"] ** 3, res["l.x"], rtol=0, atol=1e-8)
        assert any("mxstep" in m for m in res.stats["solver_messages"]), res.stats["solver_messages"]
    for res in out["quiet"]:
        assert res.success and res.stats["solver_messages"] == []
        # and the oscillator is the oscillator: phi = 0.5 cos(sqrt(c/J) t) (rtol 1e-8, 2 s, amplitude 0.5)
        assert abs(res["j1.phi"][-1] - 0.5 * np.cos(np.sqrt(100.0 / 0.1) * 2.0)) < 1e-5
    captured = capfd.readouterr()
    assert captured.err == "", captured.err[:500]
