"""mechnet.inertia: the shape table against Tenenbaum's Appendix C, checked twice.

Each shape is compared with its textbook formula written out here (rtol 1e-12:
the same arithmetic in a different order), and a few shapes with an independent
integration of their mass distribution, so a typo cannot hide in both places.
"""
import numpy as np
import pytest
from scipy import integrate

from mechnet.core.errors import ParameterError
from mechnet import inertia


def rotation_about(axis, angle):
    """Rodrigues' formula, written here so the tests do not lean on mechnet's kinematics."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def diag_with(about, across, axis):
    moments = [across] * 3
    moments[axis] = about
    return np.diag(moments)


m, r, r1, r2, h, L, a, b, c = 2.0, 0.3, 0.1, 0.25, 0.8, 1.2, 0.4, 0.7, 0.9

TABLE = [  # (name, tensor from mechnet, textbook formula) for a symmetry axis along z
    ("rod", inertia.rod(m, L, axis=2), diag_with(0.0, m * L**2 / 12, 2)),
    ("ring", inertia.ring(m, r), diag_with(m * r**2, m * r**2 / 2, 2)),
    ("disc", inertia.disc(m, r), diag_with(m * r**2 / 2, m * r**2 / 4, 2)),
    ("cylinder", inertia.cylinder(m, r, L), diag_with(m * r**2 / 2, m * (3 * r**2 + L**2) / 12, 2)),
    ("hollow_cylinder", inertia.hollow_cylinder(m, r1, r2, L),
     diag_with(m * (r1**2 + r2**2) / 2, m * (3 * (r1**2 + r2**2) + L**2) / 12, 2)),
    ("thin tube", inertia.hollow_cylinder(m, r, r, L), diag_with(m * r**2, m * (6 * r**2 + L**2) / 12, 2)),
    ("solid tube", inertia.hollow_cylinder(m, 0.0, r, L), inertia.cylinder(m, r, L)),
    ("sphere", inertia.sphere(m, r), np.eye(3) * 2 / 5 * m * r**2),
    ("spherical_shell", inertia.spherical_shell(m, r), np.eye(3) * 2 / 3 * m * r**2),
    ("cone", inertia.cone(m, r, h), diag_with(3 / 10 * m * r**2, 3 / 80 * m * (4 * r**2 + h**2), 2)),
    ("plate", inertia.plate(m, a, b), np.diag([m * b**2 / 12, m * a**2 / 12, m * (a**2 + b**2) / 12])),
    ("box", inertia.box(m, a, b, c), np.diag([m * (b**2 + c**2), m * (a**2 + c**2), m * (a**2 + b**2)]) / 12),
]


@pytest.mark.parametrize("name, tensor, textbook", TABLE, ids=[row[0] for row in TABLE])
def test_shape_matches_textbook_formula(name, tensor, textbook):
    """rtol 1e-12, atol 1e-15 kg·m² (moments are ~1e-2 kg·m²): exact formulas, rounding only."""
    assert tensor.shape == (3, 3)
    np.testing.assert_allclose(tensor, textbook, rtol=1e-12, atol=1e-15)
    assert inertia.inertia_problem(tensor) is None


@pytest.mark.parametrize("shape, args", [(inertia.rod, (m, L)), (inertia.ring, (m, r)), (inertia.disc, (m, r)),
                                         (inertia.cylinder, (m, r, L)), (inertia.hollow_cylinder, (m, r1, r2, L)),
                                         (inertia.cone, (m, r, h))])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_symmetry_axis_argument_moves_the_axial_moment(shape, args, axis):
    """The tensor for `axis` is the z-axis tensor with its diagonal permuted (exact, rtol 1e-15)."""
    along_z = np.diag(shape(*args, axis=2))
    expected = np.full(3, along_z[0])
    expected[axis] = along_z[2]
    np.testing.assert_allclose(shape(*args, axis=axis), np.diag(expected), rtol=1e-15)


def test_plate_edges_follow_the_lower_then_higher_in_plane_axis():
    """axis=1: a along x, b along z, so I_zz = m a²/12 and I_xx = m b²/12 (rtol 1e-12)."""
    np.testing.assert_allclose(inertia.plate(m, a, b, axis=1),
                               np.diag([m * b**2 / 12, m * (a**2 + b**2) / 12, m * a**2 / 12]), rtol=1e-12)


def test_cone_mass_centre_is_a_quarter_height_above_the_base():
    assert inertia.cone_mass_centre(h) == pytest.approx(h / 4, rel=1e-15)


# ---- independent integration of the mass distribution ---------------------------------------

def tensor_by_quadrature(density_region, volume_element=None):
    """Mass, mass centre and tensor about that centre of a uniform solid of revolution about z,
    integrated in cylindrical coordinates (z, s, θ) with scipy's tplquad.

    density_region = (z0, z1, s_min(z), s_max(z)); the volume element is s ds dθ dz.
    """
    z0, z1, s_lo, s_hi = density_region

    def integral(f):
        value, _err = integrate.tplquad(lambda th, s, z: f(s * np.cos(th), s * np.sin(th), z) * s,
                                        z0, z1, s_lo, s_hi, 0.0, 2 * np.pi, epsabs=1e-13, epsrel=1e-11)
        return value

    volume = integral(lambda x, y, z: 1.0)
    centre = np.array([integral(lambda x, y, z, k=k: (x, y, z)[k]) for k in range(3)]) / volume
    I = np.empty((3, 3))
    for i in range(3):
        for j in range(i, 3):
            def element(x, y, z, i=i, j=j):
                d = np.array([x, y, z]) - centre
                return (d @ d) * (i == j) - d[i] * d[j]
            I[i, j] = I[j, i] = integral(element) / volume  # per unit mass
    return volume, centre, I


def test_cone_by_quadrature():
    """Cone with its base on z = 0 and apex at z = h: radius r (1 − z/h) at height z.

    Polynomial integrands, so quadrature is exact to rounding: rtol 1e-8, atol 1e-10·m r²
    for the zero products of inertia. Also checks the volume π r² h / 3 and the mass centre.
    """
    volume, centre, I_per_mass = tensor_by_quadrature((0.0, h, 0.0, lambda z: r * (1 - z / h)))
    assert volume == pytest.approx(np.pi * r**2 * h / 3, rel=1e-8)
    np.testing.assert_allclose(centre, [0, 0, inertia.cone_mass_centre(h)], atol=1e-10 * h)
    np.testing.assert_allclose(inertia.cone(m, r, h), m * I_per_mass, rtol=1e-8, atol=1e-10 * m * r**2)


def test_hollow_cylinder_by_quadrature():
    """Tube r1 ≤ s ≤ r2, −L/2 ≤ z ≤ L/2: rtol 1e-8, atol 1e-10·m r2² (as for the cone)."""
    _volume, centre, I_per_mass = tensor_by_quadrature((-L / 2, L / 2, r1, r2))
    np.testing.assert_allclose(centre, 0.0, atol=1e-10 * L)
    np.testing.assert_allclose(inertia.hollow_cylinder(m, r1, r2, L), m * I_per_mass,
                               rtol=1e-8, atol=1e-10 * m * r2**2)


def test_spherical_shell_and_ring_by_monte_carlo():
    """Points spread uniformly over the shell (normalised Gaussians) and the ring (uniform angle).

    200 000 samples with seed 20: the sample mean of x² etc. has a relative standard error
    of about 0.2 %, so rtol 1e-2 is about 5 standard errors; products of inertia, whose exact
    value is 0 (standard error ≈ 4e-4·m r²), get atol 1e-2·m r².
    """
    rng = np.random.default_rng(20)
    n = 200_000
    points = rng.standard_normal((n, 3))
    points *= r / np.linalg.norm(points, axis=1, keepdims=True)
    angle = rng.uniform(0, 2 * np.pi, n)
    ring = np.column_stack([r * np.cos(angle), r * np.sin(angle), np.zeros(n)])
    for sample, tensor in [(points, inertia.spherical_shell(m, r)), (ring, inertia.ring(m, r))]:
        # m · mean of (|p|² 1 − p pᵀ) over the samples
        sampled = m * (np.mean(np.sum(sample**2, axis=1)) * np.eye(3) - sample.T @ sample / n)
        np.testing.assert_allclose(sampled, tensor, rtol=1e-2, atol=1e-2 * m * r**2)


# ---- transfer, rotation, composite -----------------------------------------------------------

def test_parallel_axis_round_trip():
    """about_point then about_mass_centre gives back the tensor: rtol 1e-12 of its largest entry."""
    I_cm = inertia.rotate(inertia.box(m, a, b, c), rotation_about([1, 2, 3], 0.7))
    r_cm, point = np.array([0.1, -0.2, 0.3]), np.array([1.5, 0.4, -2.0])
    I_point = inertia.about_point(I_cm, m, r_cm, point)
    d = point - r_cm  # the parallel-axis theorem written out here
    np.testing.assert_allclose(I_point, I_cm + m * ((d @ d) * np.eye(3) - np.outer(d, d)), rtol=1e-12)
    np.testing.assert_allclose(inertia.about_mass_centre(I_point, m, r_cm, point), I_cm,
                               rtol=0, atol=1e-12 * np.abs(I_cm).max())
    np.testing.assert_allclose(inertia.transfer(I_cm, m, d), I_point, rtol=1e-15)


def test_rotated_box():
    """R diag Rᵀ, and the moment about the rotated edge direction R e_k is the k-th edge moment
    (rtol 1e-12); a quarter turn about z swaps the edges a and b exactly (atol 1e-15 kg·m²)."""
    R = rotation_about([0.3, -1.0, 0.5], 1.1)
    principal = inertia.box(m, a, b, c)
    turned = inertia.rotate(principal, R)
    np.testing.assert_allclose(turned, R @ principal @ R.T, rtol=1e-12)
    for k in range(3):
        assert R[:, k] @ turned @ R[:, k] == pytest.approx(principal[k, k], rel=1e-12)
    np.testing.assert_allclose(inertia.rotate(principal, rotation_about([0, 0, 1], np.pi / 2)),
                               inertia.box(m, b, a, c), atol=1e-15)


def test_two_cubes_make_a_box():
    """Two cubes of edge a side by side along x are a 2a × a × a box of mass 2m (rtol 1e-12)."""
    cube = inertia.box(m, a, a, a)
    m_total, r_total, I_total = inertia.composite([(m, [a / 2, 1.0, 0], cube), (m, [-a / 2, 1.0, 0], cube)])
    assert m_total == 2 * m
    np.testing.assert_allclose(r_total, [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(I_total, inertia.box(2 * m, 2 * a, a, a), rtol=1e-12)


def test_rod_turned_into_z_by_the_part_rotation():
    """A rod along its own x, rotated a quarter turn about y, is a rod along z (atol 1e-15 kg·m²)."""
    _m, _r, I = inertia.composite([(m, [0, 0, 0], inertia.rod(m, L, axis=0), rotation_about([0, 1, 0], -np.pi / 2))])
    np.testing.assert_allclose(I, inertia.rod(m, L, axis=2), atol=1e-15)


def test_composite_principal_axes_against_eigh():
    """A tilted disc on a rod with an off-centre sphere, assembled here by hand: the composite
    tensor agrees to rtol 1e-12; principal moments match np.linalg.eigh of the hand tensor
    (rtol 1e-12) and the axes are a right-handed frame that diagonalises it (atol 1e-12·|I|)."""
    R_disc = rotation_about([1, 1, 0], 0.4)
    parts = [(1.0, np.array([0.5, 0, 0]), inertia.rod(1.0, 1.0, axis=0), np.eye(3)),
             (3.0, np.array([1.0, 0.1, 0]), inertia.disc(3.0, 0.2, axis=0), R_disc),
             (0.5, np.array([0.2, -0.3, 0.4]), inertia.sphere(0.5, 0.05), np.eye(3))]
    masses = np.array([p[0] for p in parts])
    centre = sum(mk * rk for mk, rk, _I, _R in parts) / masses.sum()
    by_hand = np.zeros((3, 3))
    for mk, rk, Ik, Rk in parts:
        d = rk - centre
        by_hand += Rk @ Ik @ Rk.T + mk * ((d @ d) * np.eye(3) - np.outer(d, d))

    m_total, r_total, I_total = inertia.composite(parts)
    assert m_total == pytest.approx(4.5, rel=1e-15)
    np.testing.assert_allclose(r_total, centre, rtol=1e-12)
    np.testing.assert_allclose(I_total, by_hand, rtol=1e-12)

    moments, axes = inertia.principal_axes(I_total)
    np.testing.assert_allclose(moments, np.linalg.eigh(by_hand)[0], rtol=1e-12)
    scale = np.abs(by_hand).max()
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-12)
    assert np.linalg.det(axes) == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(axes.T @ by_hand @ axes, np.diag(moments), atol=1e-12 * scale)


# ---- bad input -------------------------------------------------------------------------------

@pytest.mark.parametrize("call, culprit", [
    (lambda: inertia.rod(0.0, 1.0), "rod: m = 0.0"),
    (lambda: inertia.ring(1.0, -0.1), "ring: radius = -0.1"),
    (lambda: inertia.disc(1.0, float("nan")), "disc: radius = nan"),
    (lambda: inertia.cylinder(1.0, 0.1, 0), "cylinder: length = 0"),
    (lambda: inertia.hollow_cylinder(1.0, 0.3, 0.2, 1.0), "hollow_cylinder: inner = 0.3"),
    (lambda: inertia.hollow_cylinder(1.0, -0.1, 0.2, 1.0), "hollow_cylinder: inner = -0.1"),
    (lambda: inertia.cone(1.0, 0.1, -2.0), "cone: height = -2.0"),
    (lambda: inertia.cone_mass_centre(0.0), "cone_mass_centre: height = 0.0"),
    (lambda: inertia.plate(1.0, 0.1, 0.2, axis=3), "plate: axis = 3"),
    (lambda: inertia.box(-1.0, 1, 1, 1), "box: m = -1.0"),
    (lambda: inertia.sphere("2", 1.0), "sphere: m = '2'"),
    (lambda: inertia.spherical_shell(1.0, 0), "spherical_shell: radius = 0"),
    (lambda: inertia.rotate(np.eye(3), np.diag([1.0, 1.0, -1.0])), "rotate: R"),
    (lambda: inertia.rotate(np.eye(3), 2 * np.eye(3)), "rotate: R"),
    (lambda: inertia.composite([(1.0, [0, 0, 0], np.eye(3)), (0.0, [1, 0, 0], np.eye(3))]),
     "composite: parts[1].m = 0.0"),
    (lambda: inertia.composite([(1.0, [0, 0, 0], np.eye(3), np.diag([-1.0, 1, 1]))]), "composite: parts[0].R"),
    (lambda: inertia.composite([]), "composite: parts is empty"),
])
def test_bad_input_names_the_argument(call, culprit):
    with pytest.raises(ParameterError) as error:
        call()
    assert culprit in str(error.value)
