"""Gyroscope on a gimbal: a fast rotor on a horizontal arm, released, precesses instead of falling.

A gimbal (Cardan suspension) carries a disc rotor (1 kg, radius 5 cm, C = ½ m r²) at the end of an
arm l = 0.1 m long: World → `outer` Revolute about the vertical z (the outer ring, with its own
inertia) → `inner` Revolute about x (tilts the arm, horizontal along +y at 0) → arm → `spin`
Revolute about the arm's y axis → rotor. Gravity −z. The rotor spins at ω_s = 300 rad/s; the rest
is released from rest with the arm horizontal. Gravity's torque m·g·l about x does not drop the
arm: it turns the spin's angular momentum C·ω_s about the vertical, so the outer ring precesses at
a mean rate near Ω ≈ m·g·l/(C·ω_s) ≈ 2.6 rad/s (2.56 simulated: the outer ring's inertia and the
nutation take a little). Released from rest, the rotor's axis traces cusps: the ring's speed pulses
between 0 and about 2Ω while the arm nods down by up to 0.2 rad and back, at the nutation frequency
(≈ C·ω_s/A, A the inertia about x at the pivot). No reference: the released motion has no simple
closed form.
"""
import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

M_ROTOR, R_ROTOR, ARM, G = 1.0, 0.05, 0.1, 9.81     # kg, m, m, m/s²
M_RING, R_RING = 0.3, 0.12                          # kg, m: the outer gimbal ring
SPIN = 300.0                                        # rad/s
C = 0.5 * M_ROTOR * R_ROTOR ** 2
OMEGA_GYRO = M_ROTOR * G * ARM / (C * SPIN)         # rad/s: the gyroscopic approximation of the precession

t_end = 4.0
plot = ["outer.phi", "outer.w", "inner.phi"]
description = (f"Gimballed gyroscope released with its arm horizontal: precession near "
               f"m·g·l/(C·ω_s) = {OMEGA_GYRO:.2f} rad/s, small nutation of the arm.")


def build() -> mn.Model:
    m = mn.Model("gyroscope")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    outer = m.add(mb.Revolute(name="outer", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
    ring = m.add(mb.Body(name="ring", m=M_RING, I=inertia.ring(M_RING, R_RING, axis=2)))
    inner = m.add(mb.Revolute(name="inner", n=[1, 0, 0], phi_start=0.0, w_start=0.0))
    arm = m.add(mb.FixedTranslation(name="arm", r=[0.0, ARM, 0.0]))
    spin = m.add(mb.Revolute(name="spin", n=[0, 1, 0], phi_start=0.0, w_start=SPIN))
    rotor = m.add(mb.Body(name="rotor", m=M_ROTOR, I=inertia.disc(M_ROTOR, R_ROTOR, axis=1)))
    m.connect(world.frame_b, outer.frame_a)
    m.connect(outer.frame_b, ring.frame_a)
    m.connect(outer.frame_b, inner.frame_a)
    m.connect(inner.frame_b, arm.frame_a)
    m.connect(arm.frame_b, spin.frame_a)
    m.connect(spin.frame_b, rotor.frame_a)
    return m
