"""Newton's cradle: five touching pendulums, the first released from 0.4 rad; rigid impacts pass it on.

Five equal balls (M, diameter DIAM) hang on massless rods of length L from pivots DIAM apart along x
(`mb.Revolute` about z, gravity along −y), so at rest each touches its neighbours. Between the joints'
1D flanges of neighbouring pendulums a `rot.HardStop` (phi_rel = φ_{i+1} − φ_i ≥ 0, restitution E)
keeps them from passing through each other. For parallel pendulums this is the exact contact: the
balls' centres are DIAM apart exactly when their angles are equal (farther when φ_{i+1} > φ_i, for
|φ| < π/2), the contact normal is then horizontal, at the lever L·cos φ from both pivots, so the
normal approach speed is L·cos φ·(ω_i − ω_{i+1}) and a restitution on it is one on the rates. (The stop
is the one of the cradle tests, tests/analytic/test_friction_impacts.py.)

The first ball is released from −A0 at rest and hits the row at a quarter of the (amplitude-dependent)
period. The touching contacts are resolved one after the other at that instant (hit0 … hit3), each
two-body impact with E = 1 exchanging the rates: the last ball leaves with the first one's speed, the
others stay at rest. It swings out to A0, comes back half a period later and the cascade runs the
other way (hit3 … hit0): the first ball swings out, and so on, the cascades alternating between the
two ends every half period. Energy (`energy.total`) and the row's angular momentum Σ J·ω are kept by
every cascade. (mechnet also fires the hanging balls' stops at round-off speeds and, on some output
grids, gets a cascade wrong: the expected failures in tests/hard/test_event_examples.py.)
`reference(t)` is the first ball's free swing until the first impact (the exact
pendulum: θ(t) = −2·asin(k·sn(K − ω0·t, k²)), k = sin(A0/2)).
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot

N = 5                                      # balls
M, DIAM, L = 0.1, 0.03, 0.25               # kg, m (ball diameter = pivot spacing), m (pivot to centre)
I_BALL = 0.4 * M * (DIAM / 2) ** 2         # kg·m²: solid sphere about its centre
G = 9.81                                   # m/s^2
A0 = 0.4                                   # rad: release angle of the first ball
E = 1.0                                    # restitution between neighbours

J = M * L ** 2 + I_BALL                    # about the pivot
W0 = np.sqrt(M * G * L / J)                # rad/s: small-swing angular frequency

t_end = 4.0
plot = ["ball0_joint.phi", "ball2_joint.phi", "ball4_joint.phi", "energy.total"]
description = "Newton's cradle: five touching pendulums, rigid impacts passing the swing along the row."


def build(e: float = E, n: int = N, a0: float = A0) -> mn.Model:
    m = mn.Model("newtons_cradle")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    support = m.add(rot.Fixed(name="support"))
    joints = []
    for i in range(n):
        pivot = m.add(mb.FixedTranslation(name=f"pivot{i}", r=[DIAM * i, 0.0, 0.0]))
        joint = m.add(mb.Revolute(name=f"ball{i}_joint", n=[0, 0, 1], use_flange=True,
                                  phi_start=-a0 if i == 0 else 0.0, w_start=0.0))
        ball = m.add(mb.Body(name=f"ball{i}", m=M, r_cm=[0.0, -L, 0.0], I=np.eye(3) * I_BALL))
        m.connect(world.frame_b, pivot.frame_a)
        m.connect(pivot.frame_b, joint.frame_a)
        m.connect(joint.frame_b, ball.frame_a)
        m.connect(joint.support, support.flange)
        joints.append(joint)
    for i in range(n - 1):                 # ball i+1 never to the left of ball i
        hit = m.add(rot.HardStop(name=f"hit{i}", phi_min=0.0, phi_max=np.pi, e=e))
        m.connect(joints[i].axis, hit.flange_a)
        m.connect(hit.flange_b, joints[i + 1].axis)
    m.add(mb.SystemEnergy(name="energy"))
    return m


def period(a0: float = A0) -> float:
    """The exact period of each pendulum swinging with amplitude a0: (2/π)·K(sin²(a0/2))·2π/ω0."""
    from scipy.special import ellipk

    return 4.0 * ellipk(np.sin(a0 / 2) ** 2) / W0


def reference(t):
    """The first ball's swing from −A0 until it reaches the row at a quarter period (NaN after)."""
    from scipy.special import ellipj, ellipk

    t = np.asarray(t, dtype=float)
    k2 = np.sin(A0 / 2) ** 2
    sn = ellipj(ellipk(k2) - W0 * t, k2)[0]
    free = t < 0.25 * period() * 0.999
    return {"ball0_joint.phi": np.where(free, -2 * np.arcsin(np.sqrt(k2) * sn), np.nan)}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end, n_out=801, rtol=1e-10, atol=1e-12)
    res.plot(plot).savefig("newtons_cradle.png")
    print([(round(e.t, 6), e.cause.split(" ")[0]) for e in res.events])
