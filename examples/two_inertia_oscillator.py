"""Two inertias on springs, one damped: a linear 2-DOF torsional oscillator with a closed-form check.

fixed ── spring (c1) ── j1 ── spring2 (c2) ── j2 ──┐
  └──────────────── damper (d) ────────────────────┘

j1 starts deflected by 0.5 rad, everything else at rest. The system is linear,
so `reference(t)` is the exact solution exp(A t) x0; the demo prints the
simulation's deviation from it, and the damper makes the energy decay.
"""
import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot

C1, C2 = 100.0, 50.0  # N*m/rad
J1, J2 = 0.1, 0.2  # kg*m^2
D = 0.05  # N*m*s/rad
PHI1_START = 0.5  # rad

t_end = 5.0
plot = ["j1.phi", "j2.phi"]


def build() -> mn.Model:
    m = mn.Model("two_inertia_oscillator")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=C1))
    j1 = m.add(rot.Inertia(name="j1", J=J1, phi_start=PHI1_START, w_start=0.0))
    spring2 = m.add(rot.Spring(name="spring2", c=C2))
    j2 = m.add(rot.Inertia(name="j2", J=J2, phi_start=0.0, w_start=0.0))
    damper = m.add(rot.Damper(name="damper", d=D))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j1.flange_a)
    m.connect(j1.flange_b, spring2.flange_a)
    m.connect(spring2.flange_b, j2.flange_a)
    m.connect(j2.flange_b, damper.flange_b)
    m.connect(damper.flange_a, fixed.flange)
    return m


def _system_matrix() -> np.ndarray:
    """x = (phi1, phi2, w1, w2):  J1 a1 = -c1 phi1 + c2 (phi2 - phi1),  J2 a2 = -c2 (phi2 - phi1) - d w2."""
    return np.array([
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [-(C1 + C2) / J1, C2 / J1, 0.0, 0.0],
        [C2 / J2, -C2 / J2, 0.0, -D / J2],
    ])


def reference(t):
    """Exact solution x(t) = expm(A t) x0 of the linear system, per dotted name."""
    from scipy.linalg import expm

    a = _system_matrix()
    x0 = np.array([PHI1_START, 0.0, 0.0, 0.0])
    x = np.array([expm(a * tk) @ x0 for tk in np.atleast_1d(np.asarray(t, dtype=float))])
    return {"j1.phi": x[:, 0], "j2.phi": x[:, 1], "j1.w": x[:, 2], "j2.w": x[:, 3]}


if __name__ == "__main__":
    from pathlib import Path

    import matplotlib
    matplotlib.use("Agg")

    cm = build().compile()
    print(cm.summary())
    res = cm.simulate(t_end)
    for name, expected in reference(res.t).items():
        print(f"max |{name} - reference| = {np.max(np.abs(res[name] - expected)):.3e}")
    png = Path.cwd() / f"{Path(__file__).stem}.png"
    res.plot(plot).savefig(png)
    print(f"wrote {png}")
