"""Slider-crank with a flywheel and a gas-spring piston: a closed loop through a prismatic joint.

Planar mechanism in the x–y plane, gravity along −y. The crank (length R) turns
about the origin on `crank_joint` (Revolute about z) and carries a flywheel
(a disc on the crank axis); the connecting rod (length L) hangs from the crank
pin on `rod_joint`; the piston slides along x on `slider` (a Prismatic from the
world, use_flange=True) and is pinned to the rod by `wrist_pin`, which is
wired last and closes the loop. The compiler picks the cut joint itself (it
names it in `summary()`) and drops the loop's three redundant out-of-plane
constraints. Piston position (wrist pin from the crank centre):
x = R cos θ + √(L² − R² sin² θ), from L − R (bottom dead centre, θ = π) to
L + R (top dead centre, θ = 0).

The piston force is 1D translational: the slider's axis flange is pushed by a
`tr.Spring` from the cylinder head at HEAD, compressed over the whole stroke
(a linearised gas spring: it pushes the piston away from the head, hardest at
top dead centre). The slider's support flange is the ground (`tr.Fixed`). The
flywheel is started at W0; it carries the crank through top dead centre while
the gas spring takes and returns about 10 J, so the crank speed dips from
about 51 to 40 rad/s at every top dead centre, and the engine runs over many
revolutions (about 7 a second) without losses. `energy` (SystemEnergy) holds
the bodies' kinetic and potential energy; the gas spring's ½ c (gap − FREE)²
(`gas_energy`) is not in it.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import translational as tr
from mechnet.inertia import cylinder, rod

R, L = 0.05, 0.2                       # m: crank radius, connecting-rod length
M_CRANK, M_ROD, M_PISTON = 0.3, 0.4, 0.5          # kg
M_FLYWHEEL, R_FLYWHEEL = 2.0, 0.14     # kg, m: a disc on the crank axis (½ m r² ≈ 0.02 kg·m²)
HEAD = L + R + 0.02                    # m: cylinder head, 2 cm clearance at top dead centre
FREE = 0.12                            # m: free length of the gas spring (longer than any gap)
C_GAS = 2000.0                         # N/m
THETA0, W0 = 0.0, 40.0                 # rad, rad/s: start at top dead centre, spinning
G = 9.81

t_end = 2.0
plot = ["crank_joint.w", "slider.v", "energy.total"]
description = "Slider-crank: flywheel crank, gas-spring piston on a prismatic joint (one closed loop)."


def piston_x(theta):
    """Wrist-pin position along x for the crank angle theta (closed form)."""
    theta = np.asarray(theta, dtype=float)
    return R * np.cos(theta) + np.sqrt(L ** 2 - (R * np.sin(theta)) ** 2)


def gas_energy(s):
    """Energy stored in the gas spring at the piston position s."""
    return 0.5 * C_GAS * (HEAD - np.asarray(s, dtype=float) - FREE) ** 2


def build(theta0: float = THETA0, w0: float = W0) -> mn.Model:
    beta = -np.arcsin(R * np.sin(theta0) / L)              # rod angle from +x
    m = mn.Model("slider_crank")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    crank_j = m.add(mb.Revolute(name="crank_joint", n=[0, 0, 1], phi_start=theta0, w_start=w0))
    rod_j = m.add(mb.Revolute(name="rod_joint", n=[0, 0, 1], phi_guess=float(beta - theta0)))
    wrist = m.add(mb.Revolute(name="wrist_pin", n=[0, 0, 1], phi_guess=float(-beta)))
    slider = m.add(mb.Prismatic(name="slider", n=[1, 0, 0], use_flange=True, s_guess=float(piston_x(theta0))))
    crank = m.add(mb.FixedTranslation(name="crank", r=[R, 0, 0]))
    conrod = m.add(mb.FixedTranslation(name="conrod", r=[L, 0, 0]))
    flywheel = m.add(mb.Body(name="flywheel", m=M_FLYWHEEL, r_cm=[0, 0, 0],
                             I=cylinder(M_FLYWHEEL, R_FLYWHEEL, 0.02, axis=2)))
    crank_body = m.add(mb.Body(name="crank_body", m=M_CRANK, r_cm=[R / 2, 0, 0], I=rod(M_CRANK, R, axis=0)))
    rod_body = m.add(mb.Body(name="rod_body", m=M_ROD, r_cm=[L / 2, 0, 0], I=rod(M_ROD, L, axis=0)))
    piston = m.add(mb.Body(name="piston", m=M_PISTON, I=np.diag([2e-4, 2e-4, 2e-4])))
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, flywheel.frame_a)
    m.connect(crank_j.frame_b, crank.frame_a)
    m.connect(crank.frame_a, crank_body.frame_a)
    m.connect(crank.frame_b, rod_j.frame_a)
    m.connect(rod_j.frame_b, conrod.frame_a)
    m.connect(conrod.frame_a, rod_body.frame_a)
    m.connect(conrod.frame_b, wrist.frame_a)
    m.connect(world.frame_b, slider.frame_a)
    m.connect(slider.frame_b, piston.frame_a)
    m.connect(slider.frame_b, wrist.frame_b)                 # closes the loop at the wrist pin

    # piston force: gas spring between the slider's axis flange and the cylinder head
    ground = m.add(tr.Fixed(name="ground"))
    head = m.add(tr.Fixed(name="head", s0=HEAD))
    gas = m.add(tr.Spring(name="gas", c=C_GAS, s_rel0=FREE))
    m.connect(slider.support, ground.flange)
    m.connect(slider.axis, gas.flange_a)                      # gas.s_rel = HEAD − s, the gap
    m.connect(gas.flange_b, head.flange)

    m.add(mb.SystemEnergy(name="energy"))
    return m
