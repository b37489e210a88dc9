"""A four-bar whose crank falls under gravity onto a hard stop: impacts through a closed loop, then rest.

The crank-rocker of `four_bar.py` (ground pivots A = (0, 0) and D = (D, 0); crank A→B, coupler B→C,
rocker D→C; slender rods with mass, gravity along −y), without its motor. The crank is released at
rest at THETA0 = 1.2 rad, near the top of the linkage's potential (V is largest at θ ≈ 1.53 rad), and
turns clockwise under gravity onto a rotational hard stop at PHI_STOP = 0 rad (the crank pointing along
+x): a `rot.HardStop` between the crank joint's support (the housing) and its axis flange, phi_rel =
the crank angle, restitution E. Its upper limit π is never reached.

One degree of freedom. Each impact is solved through the whole loop (the stop's impulse on the crank
axis, the loop's velocity constraints after it): every joint rate becomes −E times itself. Between
impacts the mechanical energy (`energy.total`, SystemEnergy) is conserved; each impact keeps E² of the
kinetic energy. Gravity presses the crank into the stop (V'(0) > 0), so the rebounds shrink by E each
and accumulate; the stop then enters its rest mode (a "rest" event) and holds the linkage at the stop
for the rest of the run, its torque carrying the linkage's weight. The bounces are ever shorter near
the stop, where the crank's generalised gravity force is about constant, so their durations form a
geometric series of ratio E: rest at T∞ ≈ t_k + (t_k − t_{k−1})·E/(1 − E) from any two late impacts.

`crank_ode` is the hand-derived equation of motion of the one-coordinate linkage (Lagrange:
M(θ)·θ̈ + ½·M'(θ)·θ̇² + V'(θ) = 0, with the loop's kinematic coefficients), independent of mechnet;
`reference(t)` is its solution (scipy) until the first impact.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.inertia import rod

A, B, C, D = 0.15, 0.5, 0.4, 0.45          # m: crank, coupler, rocker, ground (Grashof crank-rocker)
MASSES = {"crank": 0.5, "coupler": 1.0, "rocker": 0.8}    # kg, slender rods
G = 9.81                                   # m/s^2
THETA0 = 1.2                               # rad: crank released at rest, from +x
PHI_STOP, PHI_MAX = 0.0, np.pi             # rad: the stop's limits on the crank angle
E = 0.6                                    # restitution of the stop

t_end = 3.0
plot = ["crank_joint.phi", "crank_joint.w", "stop.tau", "energy.total"]
description = "Four-bar whose crank falls onto a hard stop: impacts with restitution through a loop, then rest."


def assembly(theta2, a=A, b=B, c=C, d=D):
    """Coupler and rocker angles (from +x) for the crank angle theta2, open branch (rocker above the
    ground line): C where the circle of radius b about B meets the circle of radius c about D, to the
    left of the line B→D."""
    theta2 = np.asarray(theta2, dtype=float)
    bx, by = a * np.cos(theta2), a * np.sin(theta2)
    ex, ey = d - bx, -by
    L = np.hypot(ex, ey)
    p = (b ** 2 - c ** 2 + L ** 2) / (2 * L)
    h = np.sqrt(b ** 2 - p ** 2)
    cx = bx + (p * ex - h * ey) / L
    cy = by + (p * ey + h * ex) / L
    return np.arctan2(cy - by, cx - bx), np.arctan2(cy, cx - d)


def build(e: float = E, theta0: float = THETA0) -> mn.Model:
    th3, th4 = assembly(theta0)
    m = mn.Model("four_bar_stop")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    ground = m.add(mb.FixedTranslation(name="ground", r=[D, 0, 0]))
    crank_j = m.add(mb.Revolute(name="crank_joint", n=[0, 0, 1], use_flange=True, phi_start=theta0, w_start=0.0))
    coupler_j = m.add(mb.Revolute(name="coupler_joint", n=[0, 0, 1], phi_guess=float(th3 - theta0)))
    rocker_j = m.add(mb.Revolute(name="rocker_joint", n=[0, 0, 1], phi_guess=float(th4)))
    closing_j = m.add(mb.Revolute(name="closing_joint", n=[0, 0, 1], phi_guess=float(th4 - th3)))
    links = {}
    for key, length in (("crank", A), ("coupler", B), ("rocker", C)):
        link = m.add(mb.FixedTranslation(name=key, r=[length, 0, 0]))
        body = m.add(mb.Body(name=f"{key}_body", m=MASSES[key], r_cm=[length / 2, 0, 0],
                             I=rod(MASSES[key], length, axis=0)))
        m.connect(link.frame_a, body.frame_a)
        links[key] = link
    m.connect(world.frame_b, ground.frame_a)
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, links["crank"].frame_a)
    m.connect(links["crank"].frame_b, coupler_j.frame_a)
    m.connect(coupler_j.frame_b, links["coupler"].frame_a)
    m.connect(ground.frame_b, rocker_j.frame_a)
    m.connect(rocker_j.frame_b, links["rocker"].frame_a)
    m.connect(links["coupler"].frame_b, closing_j.frame_a)     # closes the loop at C
    m.connect(closing_j.frame_b, links["rocker"].frame_b)

    # the stop on the crank joint: flange_a on the housing (the joint's support), flange_b on its axis
    housing = m.add(rot.Fixed(name="housing"))
    stop = m.add(rot.HardStop(name="stop", phi_min=PHI_STOP, phi_max=PHI_MAX, e=e))
    m.connect(crank_j.support, housing.flange)
    m.connect(housing.flange, stop.flange_a)
    m.connect(stop.flange_b, crank_j.axis)

    m.add(mb.SystemEnergy(name="energy"))
    return m


# --- the hand-derived one-coordinate dynamics (no mechnet) -----------------------------------------

def _e(th):
    return np.array([np.cos(th), np.sin(th)])


def _e_prime(th):
    return np.array([-np.sin(th), np.cos(th)])


def kinematic_coefficients(theta2):
    """(θ3, θ4, k3, k4): the coupler and rocker angles and their rates per unit crank rate.

    The loop A·e(θ2) + B·e(θ3) = (D, 0) + C·e(θ4), differentiated:
    A·ω2·e'(θ2) + B·ω3·e'(θ3) − C·ω4·e'(θ4) = 0, two linear equations for ω3 = k3·ω2, ω4 = k4·ω2."""
    th3, th4 = (float(x) for x in assembly(theta2))
    K = np.column_stack([B * _e_prime(th3), -C * _e_prime(th4)])
    k3, k4 = np.linalg.solve(K, -A * _e_prime(theta2))
    return th3, th4, k3, k4


def mass_and_potential(theta2):
    """(M(θ2), V(θ2), V'(θ2)): generalised inertia about the crank coordinate, potential energy (zero at
    y = 0) and its derivative. M = Σ m·|∂r_cm/∂θ2|² + Σ I_cm·(∂θ_link/∂θ2)², I_cm = m·L²/12."""
    th3, th4, k3, k4 = kinematic_coefficients(theta2)
    mc, mo, mr = MASSES["crank"], MASSES["coupler"], MASSES["rocker"]
    r_cr, dr_cr = A / 2 * _e(theta2), A / 2 * _e_prime(theta2)
    r_co, dr_co = A * _e(theta2) + B / 2 * _e(th3), A * _e_prime(theta2) + B / 2 * k3 * _e_prime(th3)
    r_ro, dr_ro = np.array([D, 0.0]) + C / 2 * _e(th4), C / 2 * k4 * _e_prime(th4)
    M = (mc * dr_cr @ dr_cr + mo * dr_co @ dr_co + mr * dr_ro @ dr_ro
         + mc * A ** 2 / 12 + mo * B ** 2 / 12 * k3 ** 2 + mr * C ** 2 / 12 * k4 ** 2)
    V = G * (mc * r_cr[1] + mo * r_co[1] + mr * r_ro[1])
    dV = G * (mc * dr_cr[1] + mo * dr_co[1] + mr * dr_ro[1])
    return M, V, dV


def crank_ode(t, y, h=1e-5):
    """d/dt (θ2, ω2) from M·θ̈ + ½·M'·θ̇² + V' = 0 (M' by central difference, ~1e-10 relative)."""
    th, w = y
    M, _, dV = mass_and_potential(th)
    dM = (mass_and_potential(th + h)[0] - mass_and_potential(th - h)[0]) / (2 * h)
    return [w, -(0.5 * dM * w ** 2 + dV) / M]


def first_impact(theta0=THETA0, rtol=1e-12, atol=1e-14):
    """scipy's solution of `crank_ode` from rest at theta0 until the crank reaches the stop: (t, ω2, sol)."""
    from scipy.integrate import solve_ivp

    def hit(t, y):
        return y[0] - PHI_STOP
    hit.terminal, hit.direction = True, -1
    sol = solve_ivp(crank_ode, (0.0, 10.0), [theta0, 0.0], method="DOP853", rtol=rtol, atol=atol,
                    events=hit, dense_output=True)
    return float(sol.t_events[0][0]), float(sol.y_events[0][0][1]), sol


def reference(t):
    """The crank angle from the hand-derived dynamics until the first impact (NaN after: not compared)."""
    t = np.asarray(t, dtype=float)
    t_hit, _, sol = first_impact()
    free = t < t_hit * 0.999
    out = np.full(t.shape, np.nan)
    if np.any(free):
        out[free] = sol.sol(t[free])[0]
    return {"crank_joint.phi": out}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end, n_out=601, rtol=1e-10, atol=1e-12)
    res.plot(plot).savefig("four_bar_stop.png")
    print([(round(e.t, 6), e.kind) for e in res.events])
