"""Bad input around kinematic loops: each message names the loop, the joints and what is wrong."""
from __future__ import annotations

import pytest

import mechnet as mn
from mechnet.components import multibody as mb

from models import four_bar


def _square_loop(axes, coupler=(1.0, 0.0, 0.0), turntable=False):
    """World — pin1 — crank (0.5 up) — pin2 — coupler — pin3 — rocker (0.5 down) — pin4 — anchor (1 m) — World,
    a particle on each moving link away from its joints. `turntable`: the loop's ground turns about world x."""
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    if turntable:
        table = m.add(mb.Revolute(name="table", n=[1, 0, 0], phi_start=0.2, w_start=0.0))
        m.connect(world.frame_b, table.frame_a)
        m.connect(table.frame_b, m.add(mb.Body(name="table_body", m=1.0, I=[[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])).frame_a)
        world = table
    anchor = m.add(mb.FixedTranslation(name="anchor", r=[1.0, 0.0, 0.0]))
    pins = [m.add(mb.Revolute(name=f"pin{k + 1}", n=axes[k])) for k in range(4)]
    crank = m.add(mb.FixedTranslation(name="crank", r=[0.0, 0.5, 0.0]))
    link = m.add(mb.FixedTranslation(name="coupler", r=list(coupler)))
    rocker = m.add(mb.FixedTranslation(name="rocker", r=[0.0, -0.5, 0.0]))
    masses = [m.add(mb.Particle(name=f"mass{k}", m=1.0)) for k in range(3)]
    for a, b in [(world.frame_b, pins[0].frame_a), (pins[0].frame_b, crank.frame_a),
                 (crank.frame_b, pins[1].frame_a), (pins[1].frame_b, link.frame_a),
                 (link.frame_b, pins[2].frame_a), (pins[2].frame_b, rocker.frame_a),
                 (rocker.frame_b, pins[3].frame_b), (world.frame_b, anchor.frame_a),
                 (anchor.frame_b, pins[3].frame_a), (crank.frame_b, masses[0].frame_a),
                 (link.frame_b, masses[1].frame_a), (rocker.frame_a, masses[2].frame_a)]:
        m.connect(a, b)
    return m


def test_start_values_that_cannot_close_the_loop_name_the_loop_joints_and_residual():
    # a non-Grashof four-bar (a = 0.5, b = 0.4, c = 0.45, d = 0.6): the crank cannot reach 2.2 rad
    # (its toggle limit is arccos(−0.1875) = 1.759 rad), so no assembly exists there
    cm = four_bar(0.5, 0.4, 0.45, 0.6, theta2=1.0).compile()
    with pytest.raises(mn.InitializationError) as err:
        cm.simulate(0.1, start={"joint_a.phi": 2.2})
    text = str(err.value)
    assert "loop 1" in text and "closure residual" in text and "residual" in text
    for joint in ("joint_a", "joint_b", "joint_c", "joint_d"):
        assert joint in text
    assert "joint_a.phi = 2.2" in text


@pytest.mark.parametrize("turntable", [False, True], ids=["on the ground", "on a turntable"])
def test_loop_with_a_constant_residual_names_the_joint_that_cannot_close(turntable):
    # parallel z axes, but the coupler is offset 5 cm along z: the loop can never close along z. On a
    # ground turning about x the offset is still a constant, in the axes of the loop's root (the table)
    with pytest.raises(mn.StructureError, match=r"cannot close") as err:
        _square_loop([[0, 0, 1]] * 4, coupler=(1.0, 0.0, 0.05), turntable=turntable).compile()
    text = str(err.value)
    assert "position z" in text and "-0.05" in text
    assert "loop 1" in text and all(f"pin{k}" in text for k in range(1, 5))


def test_over_constrained_spatial_loop_names_the_joints_and_suggests_fewer_constraints():
    # four revolutes with axes z, y, x, z around a spatial loop: six closure constraints on four joint
    # coordinates, and the rank loss is not a planar loop's constant direction
    with pytest.raises(mn.StructureError, match=r"over-constrained") as err:
        _square_loop([[0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 0, 1]]).compile()
    text = str(err.value)
    assert all(f"pin{k}" in text for k in range(1, 5))
    assert "fewer constraints" in text and "prismatic along its axis" in text


def test_planar_square_loop_compiles_with_its_redundant_constraints_dropped():
    # the same loop with parallel axes is a parallelogram: one degree of freedom, three dropped constraints
    cm = _square_loop([[0, 0, 1]] * 4).compile()
    assert cm.n_states == 2
    assert "3 redundant constraint(s) dropped" in cm.summary()


def test_a_loop_driven_by_a_speed_input_asks_for_a_smooth_signal():
    """A Speed source whose w_ref is left as an external input cannot drive a loop: the loop's
    dependent joints need the crank's acceleration, the derivative of the input. The message names the
    input (it used to report "24 equations for 25 unknowns": the alias stage merged the source's angle
    with the crank's and lost the relation between their speeds)."""
    from mechnet.components import rotational as rot
    with pytest.raises(mn.StructureError, match=r"external input motor\.w_ref, whose derivative is unknown"):
        four_bar(drive=rot.Speed(name="motor")).compile()

