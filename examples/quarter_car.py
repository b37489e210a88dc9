"""Quarter-car suspension driven over a road profile given as a table.

road (Position, table) ── tyre spring (k_t) ── wheel (m_u) ── suspension (k_s, c_s) ── body (m_s)

Positions are measured from the static equilibrium, so gravity drops out. The
road profile is a 5 cm bump between 1.0 s and 1.3 s; each table knot is a time
event where the integrator restarts.
"""
import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components.signals import Table

M_BODY, M_WHEEL = 250.0, 35.0          # kg
K_SUSPENSION, C_SUSPENSION = 16e3, 1e3  # N/m, N*s/m
K_TYRE = 160e3                          # N/m
ROAD_TIMES = [0.0, 1.0, 1.15, 1.3, 3.0]
ROAD_HEIGHTS = [0.0, 0.0, 0.05, 0.0, 0.0]  # m

t_end = 3.0
plot = ["road.s_ref", "wheel.s", "body.s"]
description = "Quarter car over a road bump given as a table (knots are time events)."


def build(road=None) -> mn.Model:
    m = mn.Model("quarter_car")
    profile = road if road is not None else Table(ROAD_TIMES, ROAD_HEIGHTS)
    road_src = m.add(tr.Position(name="road", s_ref=profile))
    tyre = m.add(tr.Spring(name="tyre", c=K_TYRE))
    wheel = m.add(tr.Mass(name="wheel", m=M_WHEEL, s_start=0.0, v_start=0.0))
    suspension = m.add(tr.SpringDamper(name="suspension", c=K_SUSPENSION, d=C_SUSPENSION))
    body = m.add(tr.Mass(name="body", m=M_BODY, s_start=0.0, v_start=0.0))
    m.connect(road_src.flange, tyre.flange_a)
    m.connect(tyre.flange_b, wheel.flange_a)
    m.connect(wheel.flange_b, suspension.flange_a)
    m.connect(suspension.flange_b, body.flange_a)
    return m


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end)
    res.plot(plot).savefig("quarter_car.png")
