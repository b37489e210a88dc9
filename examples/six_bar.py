"""Watt six-bar: two kinematic loops of seven revolute joints, the crank turned at constant speed.

Planar mechanism in the x–y plane, every pin a plain `Revolute` about z,
gravity along −y. Six links (ground, crank, coupler 1, the ternary rocker,
coupler 2, output rocker) and seven pins, so 3·(6 − 1) − 2·7 = 1 degree of
freedom. Ground pivots A = (0, 0), D and G.

- Loop 1 (a crank-rocker four-bar): crank A→B, coupler 1 B→C, ternary rocker
  D→C. The ternary rocker carries a third pin E (length DE, at ALPHA from D→C).
- Loop 2 (a rocker-rocker four-bar driven by the first): coupler 2 E→F,
  output rocker G→F.

The loops share the ternary rocker and the ground (a Watt II chain: two
four-bars in series). The compiler finds two loops, cuts one pin in each and
drops the three redundant out-of-plane constraints of each. The assembly
guesses of all seven joints come from two successive circle intersections
(`assembly`), on the branch chosen by SIDE1, SIDE2. Every moving link has mass;
a flywheel sits on the crank.

Drive (through the crank joint's 1D flange, support to a `rot.Fixed`):

- "speed" (the scene): a `rot.Speed` source with `signals.Constant(W_CRANK)`
  turns the crank at constant speed; the degree of freedom is taken, the only
  state is the source's angle, and `motor.flange.tau` is the torque the source
  needs (minus: into the source). The output rocker swings about 110°.
- "torque" (`build(drive="torque")`): a DC-motor characteristic
  tau = TAU_STALL·(1 − w/W_NOLOAD), a `rot.ConstantTorque` plus a `rot.Damper`
  to the housing; the crank starts at rest. One degree of freedom: 2 states.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import signals as sig
from mechnet.inertia import rod

# geometry (m, rad): loop 1 is Grashof with the crank shortest (a crank-rocker)
A_CRANK, B_COUPLER, C_ROCKER = 0.1, 0.4, 0.3
D_PIVOT = np.array([0.35, 0.0])
DE, ALPHA = 0.25, np.radians(-50.0)        # the ternary rocker's third pin E, from D, at ALPHA from D→C
E_COUPLER, G_ROCKER = 0.3, 0.3             # coupler 2 E→F, output rocker G→F
G_PIVOT = np.array([0.5, 0.1])
SIDE1, SIDE2 = +1, +1                      # assembly branches: C left of B→D, F left of E→G
# masses (kg): slender rods, the ternary rocker a thin triangular plate
M_CRANK, M_COUPLER1, M_ROCKER, M_COUPLER2, M_OUTPUT = 0.3, 0.8, 1.0, 0.6, 0.6
M_FLYWHEEL, J_FLYWHEEL = 2.0, 0.05          # kg, kg·m²: flywheel on the crank axis (evens out the links' inertia)
THETA0 = 0.0                               # rad: initial crank angle
W_CRANK = 2 * np.pi                        # rad/s: "speed" drive, one crank turn per second
TAU_STALL, W_NOLOAD = 6.0, 12.0            # N·m, rad/s: "torque" drive, the motor's torque–speed line
G = 9.81

t_end = 3.0
plot = ["rocker_joint.phi", "output_joint.phi", "pin_f.phi", "motor.flange.tau"]
description = "Watt six-bar (two loops, seven revolute joints), crank turned at constant speed."


def _intersect(P, rp, Q, rq, side):
    """The intersection of the circle (P, rp) with the circle (Q, rq) to the left (side=+1) of P→Q."""
    ex, ey = Q[0] - P[0], Q[1] - P[1]
    L = np.hypot(ex, ey)
    p = (rp ** 2 - rq ** 2 + L ** 2) / (2 * L)
    h = np.sqrt(rp ** 2 - p ** 2)
    return np.array([P[0] + (p * ex - side * h * ey) / L, P[1] + (p * ey + side * h * ex) / L])


def points(theta2):
    """Pin positions B, C, E, F (world x, y) for the crank angle theta2 (a number)."""
    B = A_CRANK * np.array([np.cos(theta2), np.sin(theta2)])
    C = _intersect(B, B_COUPLER, D_PIVOT, C_ROCKER, SIDE1)
    th4 = np.arctan2(C[1] - D_PIVOT[1], C[0] - D_PIVOT[0])
    E = D_PIVOT + DE * np.array([np.cos(th4 + ALPHA), np.sin(th4 + ALPHA)])
    F = _intersect(E, E_COUPLER, G_PIVOT, G_ROCKER, SIDE2)
    return B, C, E, F


def assembly(theta2):
    """Absolute link angles (from +x) for the crank angle theta2: a dict with keys
    crank, coupler1, rocker (the direction D→C), coupler2, output. Accepts arrays."""
    out = {k: [] for k in ("crank", "coupler1", "rocker", "coupler2", "output")}
    for th in np.atleast_1d(np.asarray(theta2, dtype=float)):
        B, C, E, F = points(th)
        out["crank"].append(th)
        out["coupler1"].append(np.arctan2(C[1] - B[1], C[0] - B[0]))
        out["rocker"].append(np.arctan2(C[1] - D_PIVOT[1], C[0] - D_PIVOT[0]))
        out["coupler2"].append(np.arctan2(F[1] - E[1], F[0] - E[0]))
        out["output"].append(np.arctan2(F[1] - G_PIVOT[1], F[0] - G_PIVOT[0]))
    return {k: np.array(v) for k, v in out.items()}


def joint_angles(theta2):
    """The seven joint coordinates (relative angles, frame_a → frame_b) for the crank angle theta2."""
    th = assembly(theta2)
    return {"crank_joint": th["crank"],
            "coupler1_joint": th["coupler1"] - th["crank"],
            "pin_c": th["rocker"] - th["coupler1"],
            "rocker_joint": th["rocker"],
            "pin_e": th["coupler2"] - th["rocker"],
            "output_joint": th["output"],
            "pin_f": th["output"] - th["coupler2"]}


def _rod_link(m, name, length, mass):
    link = m.add(mb.FixedTranslation(name=name, r=[length, 0, 0]))
    body = m.add(mb.Body(name=f"{name}_body", m=mass, r_cm=[length / 2, 0, 0], I=rod(mass, length, axis=0)))
    m.connect(link.frame_a, body.frame_a)
    return link


def build(drive: str = "speed", theta0: float = THETA0, w_crank: float = W_CRANK, tau_stall: float = TAU_STALL,
          w_noload: float = W_NOLOAD) -> mn.Model:
    """The six-bar with the crank driven by a constant-speed source ("speed") or a DC-motor line ("torque")."""
    if drive not in ("speed", "torque"):
        raise ValueError(f"drive = {drive!r}: expected 'speed' or 'torque'")
    q0 = {k: float(v[0]) for k, v in joint_angles(theta0).items()}
    m = mn.Model("six_bar")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    ground_d = m.add(mb.FixedTranslation(name="ground_d", r=[D_PIVOT[0], D_PIVOT[1], 0]))
    ground_g = m.add(mb.FixedTranslation(name="ground_g", r=[G_PIVOT[0], G_PIVOT[1], 0]))
    z = [0, 0, 1]
    crank_start = {"phi_guess": theta0} if drive == "speed" else {"phi_start": theta0, "w_start": 0.0}
    crank_j = m.add(mb.Revolute(name="crank_joint", n=z, use_flange=True, **crank_start))
    joints = {name: m.add(mb.Revolute(name=name, n=z, phi_guess=q0[name]))
              for name in ("coupler1_joint", "pin_c", "rocker_joint", "pin_e", "output_joint", "pin_f")}

    crank = _rod_link(m, "crank", A_CRANK, M_CRANK)
    flywheel = m.add(mb.Body(name="flywheel", m=M_FLYWHEEL, I=np.diag([J_FLYWHEEL / 2, J_FLYWHEEL / 2, J_FLYWHEEL])))
    coupler1 = _rod_link(m, "coupler1", B_COUPLER, M_COUPLER1)
    coupler2 = _rod_link(m, "coupler2", E_COUPLER, M_COUPLER2)
    output = _rod_link(m, "output", G_ROCKER, M_OUTPUT)
    # the ternary rocker: frame x along D→C, pins C and E, a thin triangular plate D, C, E
    e_local = [DE * np.cos(ALPHA), DE * np.sin(ALPHA), 0.0]
    rocker_c = m.add(mb.FixedTranslation(name="rocker_c", r=[C_ROCKER, 0, 0]))
    rocker_e = m.add(mb.FixedTranslation(name="rocker_e", r=e_local))
    corners = np.array([[0.0, 0.0, 0.0], [C_ROCKER, 0.0, 0.0], e_local])
    centroid = corners.mean(axis=0)
    # thin triangle about its centroid: I_zz = m/36·(a² + b² + c²) over the side lengths; I_xx + I_yy = I_zz
    sides = np.sum((corners - np.roll(corners, 1, axis=0)) ** 2)
    izz = M_ROCKER * sides / 36.0
    rocker_body = m.add(mb.Body(name="rocker_body", m=M_ROCKER, r_cm=centroid.tolist(),
                                I=np.diag([izz / 2, izz / 2, izz])))

    m.connect(world.frame_b, ground_d.frame_a)
    m.connect(world.frame_b, ground_g.frame_a)
    # loop 1: A → crank → B → coupler 1 → C ← ternary rocker ← D
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, crank.frame_a)
    m.connect(crank_j.frame_b, flywheel.frame_a)
    m.connect(crank.frame_b, joints["coupler1_joint"].frame_a)
    m.connect(joints["coupler1_joint"].frame_b, coupler1.frame_a)
    m.connect(coupler1.frame_b, joints["pin_c"].frame_a)
    m.connect(joints["pin_c"].frame_b, rocker_c.frame_b)
    m.connect(ground_d.frame_b, joints["rocker_joint"].frame_a)
    m.connect(joints["rocker_joint"].frame_b, rocker_c.frame_a)
    m.connect(rocker_c.frame_a, rocker_e.frame_a)
    m.connect(rocker_c.frame_a, rocker_body.frame_a)
    # loop 2: E → coupler 2 → F ← output rocker ← G
    m.connect(rocker_e.frame_b, joints["pin_e"].frame_a)
    m.connect(joints["pin_e"].frame_b, coupler2.frame_a)
    m.connect(coupler2.frame_b, joints["pin_f"].frame_a)
    m.connect(joints["pin_f"].frame_b, output.frame_b)
    m.connect(ground_g.frame_b, joints["output_joint"].frame_a)
    m.connect(joints["output_joint"].frame_b, output.frame_a)

    housing = m.add(rot.Fixed(name="housing"))
    m.connect(crank_j.support, housing.flange)
    if drive == "speed":
        motor = m.add(rot.Speed(name="motor", w_ref=sig.Constant(w_crank), phi_start=theta0))
        m.connect(motor.flange, crank_j.axis)
    else:
        # DC-motor characteristic on the crank: tau = tau_stall − (tau_stall / w_noload)·w
        motor = m.add(rot.ConstantTorque(name="motor", tau_constant=tau_stall))
        back_emf = m.add(rot.Damper(name="back_emf", d=tau_stall / w_noload))
        m.connect(motor.flange, crank_j.axis)
        m.connect(back_emf.flange_a, housing.flange)
        m.connect(back_emf.flange_b, crank_j.axis)

    m.add(mb.SystemEnergy(name="energy"))
    return m
