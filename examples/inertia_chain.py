"""A chain of 20 spring-damper-coupled inertias, fixed at one end: a wave runs back from the free end.

fixed ── sd0 ── j0 ── sd1 ── j1 ── ... ── sd19 ── j19 (free)

The free end j19 starts twisted by 1 rad, the rest at 0. With c = 1e3 N*m/rad
and J = 0.01 kg*m^2 the chain is stiff-ish (highest frequency ≈ 630 rad/s),
so it shows the solver choice (`method="auto"` picks BDF for an ODE) and how
the compiled size grows linearly with the number of links.
"""
import mechnet as mn
from mechnet.components import rotational as rot

N = 20
C = 1e3  # N*m/rad
D = 0.1  # N*m*s/rad
J = 0.01  # kg*m^2

t_end = 2.0
plot = ["j0.phi", f"j{N // 2 - 1}.phi", f"j{N - 1}.phi"]


def build() -> mn.Model:
    m = mn.Model("inertia_chain")
    previous = m.add(rot.Fixed(name="fixed")).flange
    for k in range(N):
        sd = m.add(rot.SpringDamper(name=f"sd{k}", c=C, d=D))
        j = m.add(rot.Inertia(name=f"j{k}", J=J, phi_start=1.0 if k == N - 1 else 0.0, w_start=0.0))
        m.connect(previous, sd.flange_a)
        m.connect(sd.flange_b, j.flange_a)
        previous = j.flange_b
    return m


if __name__ == "__main__":
    from pathlib import Path

    import matplotlib
    matplotlib.use("Agg")

    cm = build().compile()
    print(cm.summary())
    res = cm.simulate(t_end)
    png = Path.cwd() / f"{Path(__file__).stem}.png"
    res.plot(plot).savefig(png)
    print(f"wrote {png}")
