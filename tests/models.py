"""Canonical scene factories shared by the tests."""
from __future__ import annotations

import mechnet as mn
from mechnet.components import rotational as rot


def oscillator(J=0.1, c=100.0, d=0.0, phi0=0.5, w0=0.0, name="oscillator") -> mn.Model:
    """Inertia on a torsional spring (and damper if d > 0) to a fixed housing."""
    m = mn.Model(name)
    fixed = m.add(rot.Fixed(name="fixed"))
    j1 = m.add(rot.Inertia(name="j1", J=J, phi_start=phi0, w_start=w0))
    if d > 0:
        element = m.add(rot.SpringDamper(name="spring", c=c, d=d))
    else:
        element = m.add(rot.Spring(name="spring", c=c))
    m.connect(fixed.flange, element.flange_a)
    m.connect(element.flange_b, j1.flange_a)
    return m


def inertia_chain(n=20, J=0.01, c=1e3, d=0.0, phi_last=1.0, name="chain") -> mn.Model:
    """Fixed end, then n × (spring[-damper] + inertia); the last inertia starts displaced."""
    m = mn.Model(name)
    previous = m.add(rot.Fixed(name="fixed")).flange
    for k in range(n):
        element = m.add(rot.SpringDamper(name=f"sd{k}", c=c, d=d) if d > 0 else rot.Spring(name=f"s{k}", c=c))
        inertia = m.add(rot.Inertia(name=f"j{k}", J=J, phi_start=phi_last if k == n - 1 else 0.0, w_start=0.0))
        m.connect(previous, element.flange_a)
        m.connect(element.flange_b, inertia.flange_a)
        previous = inertia.flange_b
    return m


class CartesianPendulum(mn.Component):
    """Point mass on a massless rod, written as raw equations in x, y and the multiplier lam (index 3)."""

    m = mn.Param(1.0, unit="kg", check=mn.positive)
    L = mn.Param(1.0, unit="m", check=mn.positive)
    g = mn.Param(9.81, unit="m/s^2")
    x = mn.State(unit="m", priority="default")
    y = mn.State(unit="m", priority="default")
    vx = mn.State(unit="m/s", priority="default")
    vy = mn.State(unit="m/s", priority="default")
    lam = mn.Var(unit="N/m", doc="rod force per unit length (Lagrange multiplier)")

    def equations(self):
        return [mn.Eq(mn.der(self.x), self.vx), mn.Eq(mn.der(self.y), self.vy),
                mn.Eq(self.m * mn.der(self.vx), -self.lam * self.x),
                mn.Eq(self.m * mn.der(self.vy), -self.lam * self.y - self.m * self.g),
                mn.Eq(self.x**2 + self.y**2, self.L**2, "rod length")]


def cartesian_pendulum(theta0=0.5, L=1.0, **kw) -> mn.Model:
    import math

    m = mn.Model("pendulum")
    m.add(CartesianPendulum(name="p", L=L, x_start=L * math.sin(theta0), y_guess=-L * math.cos(theta0),
                            vx_start=0.0, **kw))
    return m


class BouncingBall(mn.Component):
    """A ball falling under gravity, reflected with restitution e at h = 0 (a state event)."""

    e = mn.Param(0.8, check=mn.positive, doc="coefficient of restitution")
    g = mn.Param(9.81, unit="m/s^2")
    h = mn.State(unit="m", doc="height")
    v = mn.State(unit="m/s", doc="upward speed")

    def equations(self):
        return [mn.Eq(mn.der(self.h), self.v), mn.Eq(mn.der(self.v), -self.g)]

    def events(self):
        return [mn.When(self.h, reset={self.v: -self.e * self.v}, direction="falling", doc="impact")]


def bouncing_ball(h0=1.0, e=0.8) -> mn.Model:
    m = mn.Model("ball")
    m.add(BouncingBall(name="b", e=e, h_start=h0, v_start=0.0))
    return m


def _prescribes_motion(drive) -> bool:
    """A Speed or Position source fixes the crank's motion itself (no start values on the joint then)."""
    from mechnet.components import rotational as rot
    from mechnet.components import translational as tr
    return isinstance(drive, (rot.Speed, rot.Position, tr.Speed, tr.Position))


def four_bar(a=0.2, b=0.6, c=0.5, d=0.6, theta2=0.3, drive=None, masses=(1.0, 2.0, 1.5), g=9.81,
             name="four_bar") -> mn.Model:
    """Planar four-bar in the x–y plane, all revolute axes along z (the three out-of-plane closure
    constraints are redundant and dropped). Ground pivots A = (0, 0) and D = (d, 0); crank a from A
    at the angle theta2, coupler b, rocker c from D; slender rods m·L²/12 about their middles.

    `drive`: None (free), a rotational component connected to the crank joint's axis flange
    (a Speed source, a Torque...), returned as `m.driver`. The assembly guesses put the
    open branch (rocker above the ground line) in reach of Newton's method.
    """
    import numpy as np
    from mechnet.components import multibody as mb

    th3, th4 = four_bar_angles(a, b, c, d, theta2)
    m = mn.Model(name)
    world = m.add(mb.World(name="world", g=[0.0, -g, 0.0]))
    ground = m.add(mb.FixedTranslation(name="ground", r=[d, 0, 0]))
    crank_j = m.add(mb.Revolute(name="joint_a", n=[0, 0, 1], use_flange=drive is not None,
                                **({"phi_guess": theta2} if _prescribes_motion(drive) else
                                   {"phi_start": theta2, "w_start": 0.0})))
    coupler_j = m.add(mb.Revolute(name="joint_b", n=[0, 0, 1], phi_guess=th3 - theta2))
    rocker_j = m.add(mb.Revolute(name="joint_d", n=[0, 0, 1], phi_guess=th4))
    closing_j = m.add(mb.Revolute(name="joint_c", n=[0, 0, 1], phi_guess=th4 - th3))
    parts = {}
    for key, L, mass in (("crank", a, masses[0]), ("coupler", b, masses[1]), ("rocker", c, masses[2])):
        rod = m.add(mb.FixedTranslation(name=key, r=[L, 0, 0]))
        body = m.add(mb.Body(name=f"{key}_body", m=mass, r_cm=[L / 2, 0, 0],
                             I=np.diag([0.0, mass * L ** 2 / 12, mass * L ** 2 / 12])))
        m.connect(rod.frame_a, body.frame_a)
        parts[key] = rod
    m.connect(world.frame_b, ground.frame_a)
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, parts["crank"].frame_a)
    m.connect(parts["crank"].frame_b, coupler_j.frame_a)
    m.connect(coupler_j.frame_b, parts["coupler"].frame_a)
    m.connect(ground.frame_b, rocker_j.frame_a)
    m.connect(rocker_j.frame_b, parts["rocker"].frame_a)
    m.connect(parts["coupler"].frame_b, closing_j.frame_a)
    m.connect(closing_j.frame_b, parts["rocker"].frame_b)
    if drive is not None:
        from mechnet.components import rotational as rot
        fixed = m.add(rot.Fixed(name="fixed"))
        m.add(drive)
        m.connect(crank_j.support, fixed.flange)
        m.connect(crank_j.axis, drive.flange)
    m.driver = drive
    return m


def four_bar_angles(a, b, c, d, theta2, branch=+1):
    """Coupler and rocker angles (from +x) of the four-bar by Freudenstein's equation:
    K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4), K1 = d/a, K2 = d/c, K3 = (a² − b² + c² + d²)/(2ac),
    solved with the half-angle substitution; branch +1 is the open assembly (rocker above the ground)."""
    import numpy as np

    K1, K2, K3 = d / a, d / c, (a ** 2 - b ** 2 + c ** 2 + d ** 2) / (2 * a * c)
    A = np.cos(theta2) - K1 - K2 * np.cos(theta2) + K3
    B = -2 * np.sin(theta2)
    C = K1 - (K2 + 1) * np.cos(theta2) + K3
    th4 = np.angle(np.exp(2j * np.arctan2(-B - branch * np.sqrt(B ** 2 - 4 * A * C), 2 * A)))
    # coupler from B = a(cos θ2, sin θ2) to C = (d, 0) + c(cos θ4, sin θ4)
    th3 = np.arctan2(c * np.sin(th4) - a * np.sin(theta2), d + c * np.cos(th4) - a * np.cos(theta2))
    return th3, th4


def slider_crank(r=0.1, l=0.35, theta0=0.4, crank_drive=None, piston_drive=None, masses=(1.0, 0.8, 0.5),
                 g=9.81, name="slider_crank") -> mn.Model:
    """Planar slider-crank in the x–y plane: crank r about the origin (joint_a, axis z), connecting rod l
    (joint_b at the crank pin), wrist pin joint_c on the piston, which slides along x on `slider`
    (a Prismatic from the world). Closed-form piston position x = r cos θ + √(l² − r² sin² θ).

    `crank_drive` is connected to the crank joint's axis flange (a Speed source, a torque...),
    `piston_drive` to the slider's axis flange (a translational force or a Speed source); both become
    `use_flange=True`.
    """
    import numpy as np
    from mechnet.components import multibody as mb
    from mechnet.components import rotational as rot
    from mechnet.components import translational as tr

    beta = -np.arcsin(r * np.sin(theta0) / l)              # rod angle from +x
    x0 = r * np.cos(theta0) + l * np.cos(beta)
    m = mn.Model(name)
    world = m.add(mb.World(name="world", g=[0.0, -g, 0.0]))
    crank_j = m.add(mb.Revolute(name="joint_a", n=[0, 0, 1], use_flange=crank_drive is not None,
                                **({"phi_guess": theta0} if _prescribes_motion(crank_drive)
                                   or _prescribes_motion(piston_drive) else
                                   {"phi_start": theta0, "w_start": 0.0})))
    rod_j = m.add(mb.Revolute(name="joint_b", n=[0, 0, 1], phi_guess=beta - theta0))
    wrist = m.add(mb.Revolute(name="joint_c", n=[0, 0, 1], phi_guess=-beta))
    # a piston pushed at a prescribed speed is the mechanism's coordinate: its start position is fixed
    slider = m.add(mb.Prismatic(name="slider", n=[1, 0, 0], use_flange=piston_drive is not None,
                                **({"s_start": x0} if isinstance(piston_drive, tr.Speed) else {"s_guess": x0})))
    crank = m.add(mb.FixedTranslation(name="crank", r=[r, 0, 0]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[l, 0, 0]))
    for part, L, mass in ((crank, r, masses[0]), (rod, l, masses[1])):
        body = m.add(mb.Body(name=f"{part.name}_body", m=mass, r_cm=[L / 2, 0, 0],
                             I=np.diag([0.0, mass * L ** 2 / 12, mass * L ** 2 / 12])))
        m.connect(part.frame_a, body.frame_a)
    piston = m.add(mb.Body(name="piston", m=masses[2], I=np.diag([1e-4, 1e-4, 1e-4])))
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, crank.frame_a)
    m.connect(crank.frame_b, rod_j.frame_a)
    m.connect(rod_j.frame_b, rod.frame_a)
    m.connect(rod.frame_b, wrist.frame_a)
    m.connect(world.frame_b, slider.frame_a)
    m.connect(slider.frame_b, piston.frame_a)
    m.connect(slider.frame_b, wrist.frame_b)
    if crank_drive is not None:
        fixed = m.add(rot.Fixed(name="fixed"))
        m.add(crank_drive)
        m.connect(crank_j.support, fixed.flange)
        m.connect(crank_j.axis, crank_drive.flange if hasattr(crank_drive, "flange") else crank_drive.flange_b)
        if not hasattr(crank_drive, "flange"):
            m.connect(crank_drive.flange_a, fixed.flange)
    if piston_drive is not None:
        ground = m.add(tr.Fixed(name="ground"))
        m.add(piston_drive)
        m.connect(slider.support, ground.flange)
        m.connect(slider.axis, piston_drive.flange)
    return m


def slider_crank_x(r, l, theta):
    """Piston position of the slider-crank (wrist pin from the crank centre)."""
    import numpy as np
    return r * np.cos(theta) + np.sqrt(l ** 2 - (r * np.sin(theta)) ** 2)


def stephenson_mm(crank_angle=1.0, c=5e3, preload=2e-3, g=9.81, name="stephenson_mm") -> mn.Model:
    """A badly scaled one-degree-of-freedom planar six-bar (Stephenson III): millimetre links, gram
    masses and a stiff line spring, two loops meeting at one pin.

    Ground pivots O0 = (0, 0), O1 = (40, 0) and O2 = (80, 0) mm. Crank O0→Q (10 mm, 2 g), coupler Q→P
    (45 mm, 5 g), rocker O1→P (30 mm, 4 g), link P→R (40 mm, 5 g), rocker O2→R (30 mm, 4 g). Pin P
    joins three links: the coupler and the link are both pinned to the first rocker's tip, so the two
    loops O0-Q-P-O1 and O1-P-R-O2 share it. A line spring c (N/m) pulls the second rocker's tip R
    towards the ground point S = (100, 40) mm, stretched by `preload` at the start (10 N at the
    defaults; about 1 kHz oscillation against the grams). The assembly guesses are the closed-form
    circle intersections at `crank_angle` (crank from +x, rad).
    """
    import numpy as np
    from mechnet.components import multibody as mb

    mm = 1e-3
    O0, O1, O2, S = (np.array(v, dtype=float) * mm for v in ((0, 0), (40, 0), (80, 0), (100, 40)))
    lengths = {"crank": 10 * mm, "coupler": 45 * mm, "rocker1": 30 * mm, "link": 40 * mm, "rocker2": 30 * mm}
    masses = {"crank": 2e-3, "coupler": 5e-3, "rocker1": 4e-3, "link": 5e-3, "rocker2": 4e-3}

    def meet(A, rA, B, rB):            # the upper intersection of the circles |X − A| = rA, |X − B| = rB
        d = np.linalg.norm(B - A)
        along = (rA ** 2 - rB ** 2 + d ** 2) / (2 * d)
        e = (B - A) / d
        return A + along * e + np.sqrt(rA ** 2 - along ** 2) * np.array([-e[1], e[0]])

    Q = O0 + lengths["crank"] * np.array([np.cos(crank_angle), np.sin(crank_angle)])
    P = meet(Q, lengths["coupler"], O1, lengths["rocker1"])
    R = meet(P, lengths["link"], O2, lengths["rocker2"])
    angle = {k: float(np.arctan2(*(b - a)[::-1])) for k, (a, b) in
             {"crank": (O0, Q), "coupler": (Q, P), "rocker1": (O1, P), "link": (P, R), "rocker2": (O2, R)}.items()}

    m = mn.Model(name)
    world = m.add(mb.World(name="world", g=[0.0, -g, 0.0]))
    rods = {}
    for key, L in lengths.items():
        rod = rods[key] = m.add(mb.FixedTranslation(name=key, r=[L, 0, 0]))
        mass = masses[key]
        body = m.add(mb.Body(name=f"{key}_body", m=mass, r_cm=[L / 2, 0, 0],
                             I=np.diag([0.0, mass * L ** 2 / 12, mass * L ** 2 / 12])))
        m.connect(rod.frame_a, body.frame_a)
    ground = {}
    for key, at in (("O1", O1), ("O2", O2), ("S", S)):
        ground[key] = m.add(mb.FixedTranslation(name=f"ground_{key}", r=[at[0], at[1], 0.0]))
        m.connect(world.frame_b, ground[key].frame_a)

    def pin(name, a, b, phi):
        joint = m.add(mb.Revolute(name=name, n=[0, 0, 1], phi_guess=float(np.angle(np.exp(1j * phi)))))
        m.connect(a, joint.frame_a)
        m.connect(joint.frame_b, b)
        return joint

    crank = m.add(mb.Revolute(name="pin_O0", n=[0, 0, 1], phi_start=crank_angle, w_start=0.0))
    m.connect(world.frame_b, crank.frame_a)
    m.connect(crank.frame_b, rods["crank"].frame_a)
    pin("pin_Q", rods["crank"].frame_b, rods["coupler"].frame_a, angle["coupler"] - angle["crank"])
    pin("pin_O1", ground["O1"].frame_b, rods["rocker1"].frame_a, angle["rocker1"])
    pin("pin_P_coupler", rods["coupler"].frame_b, rods["rocker1"].frame_b, angle["rocker1"] - angle["coupler"])
    pin("pin_P_link", rods["rocker1"].frame_b, rods["link"].frame_a, angle["link"] - angle["rocker1"])
    pin("pin_O2", ground["O2"].frame_b, rods["rocker2"].frame_a, angle["rocker2"])
    pin("pin_R", rods["link"].frame_b, rods["rocker2"].frame_b, angle["rocker2"] - angle["link"])
    spring = m.add(mb.Spring(name="spring", c=c, s_unstretched=float(np.linalg.norm(S - R)) - preload))
    m.connect(rods["rocker2"].frame_b, spring.frame_a)
    m.connect(ground["S"].frame_b, spring.frame_b)
    return m


def stephenson_mm_by_hand(c=5e3, preload=2e-3, g=9.81, crank_angle=1.0):
    """`stephenson_mm` written by hand, independently of mechnet, in its one free coordinate θ (the crank
    angle): the other links from closed-form circle intersections, the motion from Lagrange's equation
    M(θ) θ̈ + ½ M'(θ) θ̇² + V'(θ) = 0. Returns (x = [θ, θ̇], ẋ, energy function E(θ, θ̇)) in CasADi."""
    import casadi as ca
    import numpy as np

    MM = 1e-3
    O0, O1, O2, S = (np.array(v, dtype=float) * MM for v in ((0, 0), (40, 0), (80, 0), (100, 40)))
    masses = {"crank": 2e-3, "coupler": 5e-3, "rocker1": 4e-3, "link": 5e-3, "rocker2": 4e-3}

    def meet(A, rA, B, rB):            # upper intersection of |X − A| = rA and |X − B| = rB
        d = ca.norm_2(B - A)
        along = (rA ** 2 - rB ** 2 + d ** 2) / (2 * d)
        e = (B - A) / d
        return A + along * e + ca.sqrt(rA ** 2 - along ** 2) * ca.vertcat(-e[1], e[0])

    th, w = ca.SX.sym("theta"), ca.SX.sym("w")
    Q = ca.DM(O0) + 10 * MM * ca.vertcat(ca.cos(th), ca.sin(th))
    P = meet(Q, 45 * MM, ca.DM(O1), 30 * MM)
    R = meet(P, 40 * MM, ca.DM(O2), 30 * MM)
    links = {"crank": (ca.DM(O0), Q, 10 * MM), "coupler": (Q, P, 45 * MM), "rocker1": (ca.DM(O1), P, 30 * MM),
             "link": (P, R, 40 * MM), "rocker2": (ca.DM(O2), R, 30 * MM)}
    M, V = 0, 0
    for key, (a, b, L) in links.items():
        centre, angle = (a + b) / 2, ca.atan2(b[1] - a[1], b[0] - a[0])
        m = masses[key]
        M += m * ca.sumsqr(ca.jacobian(centre, th)) + m * L ** 2 / 12 * ca.jacobian(angle, th) ** 2
        V += m * g * centre[1]
    R0 = np.array(ca.Function("R0", [th], [R])(crank_angle)).ravel()
    s_unstretched = np.linalg.norm(S - R0) - preload
    V += 0.5 * c * (ca.norm_2(ca.DM(S) - R) - s_unstretched) ** 2
    accel = -(0.5 * ca.jacobian(M, th) * w ** 2 + ca.jacobian(V, th)) / M
    return ca.vertcat(th, w), ca.vertcat(w, accel), ca.Function("E", [th, w], [0.5 * M * w ** 2 + V])


def double_integrator(m=1.0, v0=0.0, name="double_integrator") -> mn.Model:
    """A mass (m may be mn.tunable) pushed by the input force "push.f", at s = 0 with speed v0: the
    optimal-control tests' plant, s'' = u / m."""
    from mechnet.components import translational as tr

    model = mn.Model(name)
    mass = model.add(tr.Mass(name="mass", m=m, s_start=0.0, v_start=v0))
    push = model.add(tr.Force(name="push"))
    model.connect(push.flange, mass.flange_a)
    return model


class Relay(rot.PartialOneFlange):
    """A torque switched by the angle, with hysteresis: on (tau_on on the flange) when the angle rises
    through phi_on, off when it falls through phi_off — the test scene of a discrete mode."""

    tau_on = mn.Param(1.0, unit="N*m", doc="torque on the flange while the relay is closed")
    phi_on = mn.Param(1.0, unit="rad", doc="angle rising through which the relay closes")
    phi_off = mn.Param(0.0, unit="rad", doc="angle falling through which the relay opens")
    on = mn.Mode(0.0, doc="relay closed (1) or open (0)")
    tau = mn.Var(unit="N*m", doc="torque the relay drives its flange with")

    def equations(self):
        return [mn.Eq(self.tau, self.on * self.tau_on), mn.Eq(self.flange.tau, -self.tau)]

    def events(self):
        return [mn.When(self.flange.phi - self.phi_on, reset={self.on: 1.0}, direction="rising", doc="close"),
                mn.When(self.flange.phi - self.phi_off, reset={self.on: 0.0}, direction="falling", doc="open")]


def relay_inertia(J=0.5, w0=2.0, tau_on=-1.0, phi_on=1.0, phi_off=0.5, c=0.0, name="relay_inertia") -> mn.Model:
    """An inertia at phi = 0 with speed w0, driven by a Relay (and pulled back by a spring c to a fixed
    housing when c > 0: the relay then switches on every swing)."""
    m = mn.Model(name)
    j1 = m.add(rot.Inertia(name="j1", J=J, phi_start=0.0, w_start=w0))
    relay = m.add(Relay(name="relay", tau_on=tau_on, phi_on=phi_on, phi_off=phi_off))
    m.connect(relay.flange, j1.flange_a)
    if c > 0:
        fixed = m.add(rot.Fixed(name="fixed"))
        spring = m.add(rot.Spring(name="spring", c=c))
        m.connect(fixed.flange, spring.flange_a)
        m.connect(spring.flange_b, j1.flange_b)
    return m


class Cascade(mn.Component):
    """x grows at 1 m/s; at x = 1 the first condition sets mode a, and a's jump makes the second
    condition cross at the same instant and set mode b: event iteration through a mode."""

    x = mn.Var(unit="m")
    a = mn.Mode(0.0, doc="set when x reaches 1")
    b = mn.Mode(0.0, doc="set when a is set")

    def equations(self):
        return [mn.Eq(mn.der(self.x), 1.0)]

    def events(self):
        return [mn.When(self.x - 1.0, reset={self.a: 1.0}, direction="rising", doc="first"),
                mn.When(self.a - 0.5, reset={self.b: 1.0}, direction="rising", doc="second")]


def cascade(x0=0.3) -> mn.Model:
    m = mn.Model("cascade")
    m.add(Cascade(name="c", x_start=x0))
    return m


def stick_slip_block(push=5.0, c=10.0, mu_k=0.2, mu_s=0.3, name="stick_slip") -> mn.Model:
    """A 1 kg block on a spring (c to a wall) pushed by a constant force on a surface with friction
    (normal force 9.81 N): pushed past the static limit from the start, it breaks away at t = 0 and
    sticks again after half a period, π/√c s."""
    from mechnet.components import translational as tr
    m = mn.Model(name)
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    wall = m.add(tr.Fixed(name="wall"))
    spring = m.add(tr.Spring(name="spring", c=c))
    force = m.add(tr.ConstantForce(name="push", f_constant=push))
    ground = m.add(tr.Fixed(name="ground"))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=mu_k, mu_s=mu_s))
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    m.connect(force.flange, mass.flange_b)
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, mass.flange_b)
    return m


def stopped_oscillator(e=0.7, limit=0.05, name="stopped_oscillator") -> mn.Model:
    """A 1 kg mass on a spring (100 N/m) between hard stops at ±limit, started at 0.04 m with 1 m/s:
    it rebounds off both stops with restitution e."""
    from mechnet.components import translational as tr
    m = mn.Model(name)
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.04, v_start=1.0))
    wall = m.add(tr.Fixed(name="wall"))
    spring = m.add(tr.Spring(name="spring", c=100.0))
    stop = m.add(tr.HardStop(name="stop", s_min=-limit, s_max=limit, e=e))
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, mass.flange_b)
    return m


def pushed_block(push=0.5 * 9.81, ramp=None, v0=0.0, fn=9.81, mu_k=0.25, mu_s=0.5, stop=None, e=0.8,
                 name="pushed_block") -> mn.Model:
    """A 1 kg block ("block") on a fixed surface with friction ("fr", normal force fn), at s = 0 with speed
    v0, pushed by the force "push" (the constant `push`, or the signal `ramp`: a rising push breaks it away
    mid-run). With the defaults the static limit (μs − μk)·fn + μk·fn is exactly 0.5·9.81 in floating point
    (0.25·9.81 twice). `stop`: a HardStop ("stop", restitution e) limiting the block to s ≤ stop."""
    from mechnet.components import translational as tr
    m = mn.Model(name)
    block = m.add(tr.Mass(name="block", m=1.0, s_start=0.0, v_start=v0))
    ground = m.add(tr.Fixed(name="ground"))
    fr = m.add(tr.Friction(name="fr", fn=fn, mu_k=mu_k, mu_s=mu_s))
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, block.flange_a)
    if ramp is not None or push:
        force = m.add(tr.Force(name="push", f=ramp) if ramp is not None else tr.ConstantForce(name="push",
                                                                                           f_constant=push))
        m.connect(force.flange, block.flange_b)
    if stop is not None:
        hs = m.add(tr.HardStop(name="stop", s_min=-10.0, s_max=stop, e=e))
        m.connect(ground.flange, hs.flange_a)
        m.connect(hs.flange_b, block.flange_b)
    return m


def two_balls(s0=0.5, v0=0.0, e=0.8, mass=0.1, g=9.81, name="two_balls") -> mn.Model:
    """Two independent balls ("ball1", "ball2": `mass` kg each, both from height s0 with speed v0) above one
    rigid floor, each on its own Contact ("contact1", "contact2", restitution e) under gravity g: they land
    at the same instant."""
    from mechnet.components import translational as tr
    m = mn.Model(name)
    floor = m.add(tr.Fixed(name="floor"))
    for k in (1, 2):
        contact = m.add(tr.Contact(name=f"contact{k}", e=e))
        body = m.add(tr.Mass(name=f"ball{k}", m=mass, s_start=s0, v_start=v0))
        gravity = m.add(tr.ConstantForce(name=f"gravity{k}", f_constant=-mass * g))
        m.connect(floor.flange, contact.flange_a)
        m.connect(contact.flange_b, body.flange_a)
        m.connect(gravity.flange, body.flange_b)
    return m


def mass_line(n=3, v0=1.0, gap=0.1, e=1.0, mass=1.0, name="mass_line") -> mn.Model:
    """A translational Newton's cradle: n equal masses ("m0" … "m{n-1}") on a frictionless line, joined in
    order by rigid Contacts ("hit0" …: m{i+1} never behind m{i}, restitution e). m0 starts `gap` behind m1
    with speed v0; the others rest touching (all at s = 0)."""
    from mechnet.components import translational as tr
    m = mn.Model(name)
    masses = [m.add(tr.Mass(name=f"m{i}", m=mass, s_start=-gap if i == 0 else 0.0, v_start=v0 if i == 0 else 0.0))
              for i in range(n)]
    for i in range(n - 1):
        hit = m.add(tr.Contact(name=f"hit{i}", e=e))
        m.connect(masses[i].flange_b, hit.flange_a)
        m.connect(hit.flange_b, masses[i + 1].flange_a)
    return m


def revolute_pendulum(phi0=0.3, length=1.0, mass=1.0, name="pendulum") -> mn.Model:
    """The README's multibody pendulum: a particle of `mass` kg `length` m out along x on a revolute joint
    about z, released at phi0 rad from rest, under the World's gravity (−9.81 m/s² along y)."""
    from mechnet.components import multibody as mb
    m = mn.Model(name)
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=phi0, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[length, 0, 0]))
    bob = m.add(mb.Particle(name="bob", m=mass))
    m.connect(world.frame_b, rev.frame_a)
    m.connect(rev.frame_b, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    return m
