"""Andrews' squeezing mechanism: seven bodies, ten revolute joints, three closed loops, one degree of freedom.

The benchmark of Schiehlen (1990) as posed in Hairer & Wanner, *Solving ODEs II*, VII.7, and in the
IVP test set of Mazzia & Magherini: a planar mechanism without gravity, driven by a constant torque
MOM on the crank K1 and loaded by a stiff spring (C0, rest length L0) on K3. The crank turns about
1.3 times in T_END = 0.03 s and reaches about 1100 rad/s; the problem is a test of index-3 DAE
solvers because its speeds change fast (the spring force grows a thousandfold over a revolution).

Planar, in the x–y plane, every pin a `Revolute` about z, no gravity. Fixed points (m): the crank's
pivot O = (0, 0) and A, B, C (`POINTS`). The paper's seven coordinates are the scene's joint angles,
with the paper's signs (each `<coordinate>_joint.phi`, listed in `COORDINATES`):

- K1, the crank (`beta_joint`, O): β, the angle of K1's frame from +x; K1's pin to K2 at RR along
  its x axis, its mass centre RA from O.
- K2 (`theta_joint`, at K1's pin): θ, relative to K1; the point P at −D along its x axis (world
  P = RR·e(β) − D·e(β+θ)), its mass centre at −DA.
- K3 (`gamma_joint`, B): γ; P at −SS along its y axis (P = B + SS·(sin γ, −cos γ)), the spring's end
  at (SD, −SC) in its frame; mass centre √(SA² + SB²) from B.
- K5 (`delta_joint`, A): δ; its pin Q to K4 at ZT along its x axis; mass centre √(TA² + TB²) from A.
- K4 (`phi_joint`, at Q): φ, relative to K5; P at −E along its y axis (P = Q + E·(sin(φ+δ),
  −cos(φ+δ))); mass centre E − EA from Q, towards P.
- K7 (`epsilon_joint`, A): ε; its pin R to K6 at −U along its y axis (R = A + U·(sin ε, −cos ε));
  mass centre √(UA² + UB²) from A.
- K6 (`omega_joint`, at R): ω, relative to K7; P at ZF along its x axis; mass centre ZF − FA from R.

K2, K3, K4 and K6 meet at P: three pins there (`pin_p3`, `pin_p4`, `pin_p6`, frame_a on K2) close the
loops. Bodies on a fixed pivot (K1, K3, K5, K7) carry the paper's distance of their mass centre from
the pivot; its direction does not enter the dynamics (no gravity) and is taken along the frame's
axes as the paper's two lengths suggest. Every body is a thin plate (I_zz the paper's I, I_xx = I_yy =
I/2). The spring is a multibody line `Spring` from K3's point D to C. The start is the test set's
consistent position (`START`) at rest: β is fixed (`phi_start`, `w_start`), the others are guesses
that initialisation completes from the loop closures.

`published(t)` is the test set's solution at t = 0.03 s (PSIDE at tolerance 1e-14; `REFERENCE`), NaN
at any other time, in the form of a scene's `reference(t)`, for `mechnet.accuracy.study(...,
reference=published)`. It is not the scene's `reference`: the examples' check compares that at the
default tolerances (rtol 1e-6), which leave 2.6e-4 rad in β here (docs/accuracy.md, "The Andrews
squeezer"). The speeds reach 1.1e3 and 1.4e3 rad/s and the angles 16 rad by the end.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot

# masses (kg) and moments of inertia about the mass centres (kg·m²), bodies K1 … K7
M = (0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498)
I = (2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5)
# lengths (m), the paper's names
D, DA, E, EA = 28e-3, 115e-4, 2e-2, 1421e-5
RR, RA = 7e-3, 92e-5
SS, SA, SB, SC, SD = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
TA, TB = 2308e-5, 916e-5
U, UA, UB = 4e-2, 1228e-5, 449e-5
ZF, ZT, FA = 2e-2, 4e-2, 1421e-5
POINTS = {"A": (-0.06934, -0.00227), "B": (-0.03635, 0.03273), "C": (0.014, 0.072)}   # m, fixed points
C0, L0 = 4530.0, 7785e-5          # N/m, m: the spring
MOM = 0.033                       # N·m: the driving torque on K1

COORDINATES = ("beta", "theta", "gamma", "phi", "delta", "omega", "epsilon")
START = {"beta": -0.0617138900142764496358948458001, "theta": 0.0,
         "gamma": 0.455279819163070380255912382449, "phi": 0.222668390165885884674473185609,
         "delta": 0.487364979543842550225598953530, "omega": -0.222668390165885884674473185609,
         "epsilon": 1.23054744454982119249735015568}          # rad, consistent, at rest
T_END = 0.03
REFERENCE = {"beta": 15.81077119629904, "theta": -15.75637105984298, "gamma": 0.04082224013073101,
             "phi": -0.5347301163226948, "delta": 0.5244099658805304, "omega": 0.5347301163226948,
             "epsilon": 1.048080741042263}                    # rad at T_END (Mazzia & Magherini's test set)

t_end = T_END
plot = ["beta_joint.phi", "theta_joint.phi", "gamma_joint.phi", "beta_joint.w"]
description = "Andrews' squeezing mechanism (seven bodies, three loops), the DAE test set's benchmark."


def published(t):
    """The test set's angles at t = 0.03 s; NaN elsewhere (not compared)."""
    t = np.asarray(t, dtype=float)
    at_end = np.abs(t - T_END) <= 1e-12
    return {f"{k}_joint.phi": np.where(at_end, REFERENCE[k], np.nan) for k in COORDINATES}


def _plate(m, name, k, r_cm):
    """Body K<k> at frame_a: the paper's mass and I_zz, a thin plate (I_xx = I_yy = I_zz / 2)."""
    i = I[k - 1]
    return m.add(mb.Body(name=name, m=M[k - 1], r_cm=[r_cm[0], r_cm[1], 0.0], I=np.diag([i / 2, i / 2, i])))


def build() -> mn.Model:
    z = [0, 0, 1]
    th = START
    m = mn.Model("andrews_squeezer")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    fixed = {key: m.add(mb.FixedTranslation(name=f"point_{key.lower()}", r=[x, y, 0.0]))
             for key, (x, y) in POINTS.items()}
    for f in fixed.values():
        m.connect(world.frame_b, f.frame_a)

    def joint(key, **start):
        return m.add(mb.Revolute(name=f"{key}_joint", n=z, **start))

    def arm(name, r, frame):
        link = m.add(mb.FixedTranslation(name=name, r=[r[0], r[1], 0.0]))
        m.connect(frame, link.frame_a)
        return link

    # K1, the crank, driven by MOM through its joint's flange
    beta = m.add(mb.Revolute(name="beta_joint", n=z, use_flange=True, phi_start=th["beta"], w_start=0.0))
    m.connect(world.frame_b, beta.frame_a)
    k1 = _plate(m, "k1", 1, (RA, 0.0))
    m.connect(beta.frame_b, k1.frame_a)
    k1_pin = arm("k1_pin", (RR, 0.0), beta.frame_b)
    housing = m.add(rot.Fixed(name="housing"))
    drive = m.add(rot.ConstantTorque(name="drive", tau_constant=MOM))
    m.connect(beta.support, housing.flange)
    m.connect(drive.flange, beta.axis)

    # K2 on the crank's pin, reaching P
    theta = joint("theta", phi_guess=th["theta"])
    m.connect(k1_pin.frame_b, theta.frame_a)
    m.connect(theta.frame_b, _plate(m, "k2", 2, (-DA, 0.0)).frame_a)
    k2_p = arm("k2_p", (-D, 0.0), theta.frame_b)

    # K3 about B, with the spring's point D
    gamma = joint("gamma", phi_guess=th["gamma"])
    m.connect(fixed["B"].frame_b, gamma.frame_a)
    m.connect(gamma.frame_b, _plate(m, "k3", 3, (SA, SB)).frame_a)
    k3_p = arm("k3_p", (0.0, -SS), gamma.frame_b)
    k3_d = arm("k3_d", (SD, -SC), gamma.frame_b)
    spring = m.add(mb.Spring(name="spring", c=C0, s_unstretched=L0))
    m.connect(k3_d.frame_b, spring.frame_a)
    m.connect(fixed["C"].frame_b, spring.frame_b)

    # K5 about A, K4 on its pin Q, reaching P
    delta = joint("delta", phi_guess=th["delta"])
    m.connect(fixed["A"].frame_b, delta.frame_a)
    m.connect(delta.frame_b, _plate(m, "k5", 5, (TA, TB)).frame_a)
    k5_q = arm("k5_q", (ZT, 0.0), delta.frame_b)
    phi = joint("phi", phi_guess=th["phi"])
    m.connect(k5_q.frame_b, phi.frame_a)
    m.connect(phi.frame_b, _plate(m, "k4", 4, (0.0, -(E - EA))).frame_a)
    k4_p = arm("k4_p", (0.0, -E), phi.frame_b)

    # K7 about A, K6 on its pin R, reaching P
    epsilon = joint("epsilon", phi_guess=th["epsilon"])
    m.connect(fixed["A"].frame_b, epsilon.frame_a)
    m.connect(epsilon.frame_b, _plate(m, "k7", 7, (UA, UB)).frame_a)
    k7_r = arm("k7_r", (0.0, -U), epsilon.frame_b)
    omega = joint("omega", phi_guess=th["omega"])
    m.connect(k7_r.frame_b, omega.frame_a)
    m.connect(omega.frame_b, _plate(m, "k6", 6, (ZF - FA, 0.0)).frame_a)
    k6_p = arm("k6_p", (ZF, 0.0), omega.frame_b)

    # the three pins at P close the loops (relative angle: the body's absolute angle minus K2's)
    k2_abs = th["beta"] + th["theta"]
    for key, frame, absolute in (("p3", k3_p, th["gamma"]), ("p4", k4_p, th["phi"] + th["delta"]),
                                 ("p6", k6_p, th["omega"] + th["epsilon"])):
        pin = m.add(mb.Revolute(name=f"pin_{key}", n=z, phi_guess=absolute - k2_abs))
        m.connect(k2_p.frame_b, pin.frame_a)
        m.connect(pin.frame_b, frame.frame_b)
    return m
