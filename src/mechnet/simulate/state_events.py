"""State events for the simulation loop: armed sides, detection between monitor points, location, resets.

A component's `When(condition, reset, direction)` becomes a zero function g and
a transition. Each g is *armed* with the side it is on (+1 or −1); an event is
g reaching the other side in the declared direction. Two rules make detection
independent of the output grid and the tolerance:

- **Sides on the boundary.** Where g is on its boundary (g = 0 to within what
  the event location resolves, and always just after its own event) its side
  is the one it moves to: the sign of ġ, or of g̈ where ġ vanishes too (ġ and g̈
  are Lie derivatives along the DAE, inputs held). A directional condition that
  moves into its direction from the boundary crosses *now*: a ball placed on
  the floor at rest fires at once. After a reset the fired condition is armed
  with its new side (a bounce: h = 0, ḣ > 0, armed +, the next impact found;
  a sensor whose reset keeps ḣ < 0 has completed its crossing); one that the
  reset leaves on its boundary with ġ = 0 and g̈ pushing it across fires again at
  the same instant. A reset may make other conditions cross (jump to their other
  side, or onto their boundary moving into their direction): they fire at the
  same instant, in rounds, up to MAX_CASCADE rounds; a round that repeats an
  earlier one (the same functions firing from the same state: a ball at rest,
  whose reset v → −e·0 changes nothing) or one past that bound is an
  accumulation and stops the run. A non-directional ("both") condition fires
  on a change of sign only: one that merely leaves 0 (after resting there with
  ġ = g̈ = 0) has not crossed; a directional one leaving its boundary into its
  direction has.
- **At rest on the boundary.** A function within the round-off of the states of its boundary (a few
  ulps of each state at its scale, max(|x|, nominal)) whose rates are each within their own round-off
  or would not take it out of that within the run (|ġ|·T, |g̈|·T² below it) reads exactly 0 with
  rates 0 (`_at_rest`): it is on its boundary and not moving, on no side, and coming to rest there is
  no crossing (it stays on the side it was on). Two pendulums hanging at rest, touching, read angles
  of 1e-45 rad (the round-off of the scene's solve), and after a cradle's impact the resting balls'
  accelerations read 1e-15 rad/s² (round-off at the scale of gravity); their stops saw that wander
  across 0 as impacts, rests and releases. So touching contacts follow one law whatever their
  coordinates: impulses only where a contact closes, in cascade rounds at the instant. Only round-off
  counts, never a tolerance: a closing the integration resolves, however slow, is an impact (a band
  at atol scale let two masses at 1e-5 m/s pass through each other).
- **Excursions between monitor points.** g and ġ at both ends of each monitor
  interval define a cubic Hermite interpolant; its extrema inside the interval
  are checked too, so a whole excursion (down through zero and back) between
  two points is found and bracketed by re-integration to the extremum. A
  predicted crossing that re-integration does not confirm is searched again on
  the sub-intervals between the checked extrema.

  Why this is a guarantee and not a property of the output grid: a sign change
  at monitor points is always found, so a crossing can be missed only when g
  crosses and comes back within one monitor interval Δ while the cubic stays on
  the armed side. The cubic interpolates g with error at most Δ⁴·max|g⁗|/384
  on the interval (exact when g is at most cubic in t along the solution, as a
  ball's height in free flight), so only an excursion shallower than that bound
  can be missed. The monitor points are placed from the solver's own steps, not
  from the output grid: each piece is checked after its integration, and one
  whose monitor spacing exceeds MONITOR_REDO solver steps (the mean step of that
  piece) is integrated again at MONITOR_STEPS steps per monitor interval (at
  most twice) before "no crossing" is accepted (`pieces.py`). With Δ ≈ 2 solver
  steps the bound is of the order of the solver's own local error (a step h of
  order q ≥ 3 keeps h^(q+1)·|x^(q+1)| near the tolerance): what is missed is an
  excursion the integrator itself does not resolve, whatever n_out. (The mean
  step stands in for the local one: a piece whose solution quickens briefly is
  judged by its average; casadi.integrator reports no step sequence.) Pieces
  are capped in monitor points (memory), so a piece may be shorter than an
  output interval.

The crossing is located by Illinois regula falsi (to 1e-12 relative in time)
on a bracket whose ends have the two signs; both limits are recorded, the reset
is applied (to the states and the modes d) and the algebraic variables re-solved
with the new modes. Re-integration for the search
leaves out whole turns of periodic coordinates like every other integrator call,
and a failure in it stops the run with an `IntegrationError` and the partial
result.

**Accumulation** is decided from the event sequence alone, never from the
output grid: the events of one condition whose last three gaps shrink by a
consistent ratio r < 1 predict the accumulation point T∞ = t + gap·r/(1 − r).
When T∞ lies within ACCUMULATION_RESOLUTION time resolutions of the last event
(`_time_resolution`: the error the tolerances allow in x and z carried into g,
over the crossing speed |ġ| — below it the integration no longer fixes the
event times, and a ball's bounces drown in its atol), or a gap is within that
many location tolerances (1e-12·max(1, |t|) s), the run stops with the partial
result (a Zeno point such as a bouncing ball coming to rest). Gaps that do not
shrink (an elastic ball) never stop the run.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..caches import built
from ..core.errors import IntegrationError
from ..core.events import accumulation_time, best_accumulation_time, location_tolerance
from ..numeric import NumpyCall, mapped_in
from .events import Event
from .initialize import solve_algebraic
from .solvers import solver_message

SPLIT_DEPTH = 3          # times a predicted but unconfirmed crossing is searched again on sub-intervals
SX_SOLVE_MAX = 8         # algebraic variables up to which ż is solved symbolically in SX
MAX_CASCADE = 8          # rounds of firings at one instant (A's reset makes B cross, ...) before accumulation
ACCUMULATION_RESOLUTION = 10.0   # time resolutions of an event within which a predicted T∞ is a Zeno point


class EventSearchFailed(RuntimeError):
    """Re-integration during the crossing search failed (the solver's message is the argument)."""

    def __init__(self, t_a, t, message):
        super().__init__(message)
        self.t_a, self.t = t_a, t


def zero_rates(dae) -> ca.Function:
    """(t, x, z, u, p, d) -> [g, ġ, g̈]: the Lie derivatives of the zero functions along the DAE.

    ż comes from differentiating alg = 0 (index 1: ∂alg/∂z is regular). Inputs are held constant
    (their rate is not known to the DAE). Built in SX (fast to evaluate) unless the DAE needs MX or
    holds many algebraic variables (a symbolic solve would swell); cached on the selection."""
    return built(dae.info, "_zero_rates", lambda: _build_zero_rates(dae))[0]


def zero_rates_noise(dae) -> ca.Function:
    """(t, x, z, u, p, d) -> [g, ġ, g̈, noise]: `zero_rates` and the round-off of g (a few ulps of each
    state at its scale, max(|x|, nominal), through |∂g/∂x|, |∂g/∂z|), in one call: every evaluation
    of the rates during a run needs both (`StateEvents._rates`)."""
    return built(dae.info, "_zero_rates", lambda: _build_zero_rates(dae))[1]


def zero_rates_round_off(dae) -> ca.Function:
    """(t, x, z, u, p, d) -> [round-off of ġ, of g̈], the same way through the rates' Jacobians: a
    resting pendulum's acceleration reads 1e-15 rad/s², the round-off of the scene's solve at the scale
    of gravity, not of the angles. Costs about a Jacobian of the model: asked only where a function sits
    within g's round-off of its boundary and its rates do not settle it (`StateEvents._at_rest`)."""
    return built(dae.info, "_zero_rates", lambda: _build_zero_rates(dae))[2]


def zero_sensitivity(dae) -> ca.Function:
    """(t, x, z, u, p, d) -> [∂g/∂x, ∂g/∂z]: how the solver's errors in x and z move the zero functions."""
    return built(dae.info, "_zero_sensitivity", lambda: _build_zero_sensitivity(dae))


def _build_zero_sensitivity(dae):
    sym = ca.SX if dae.z.numel() <= SX_SOLVE_MAX else ca.MX
    try:
        args = [sym.sym(n, v.shape) for n, v in zip("txzupd", (dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))]
        g = dae.zero(*args)
    except (RuntimeError, NotImplementedError, TypeError):
        args = [ca.MX.sym(n, v.shape) for n, v in zip("txzupd", (dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))]
        g = dae.zero(*args)
    return ca.Function("zero_sensitivity", args, [ca.densify(ca.jacobian(g, args[1])),
                                                 ca.densify(ca.jacobian(g, args[2]))])


def _build_zero_rates(dae):
    """(under the build lock: building SX in two threads at once corrupts the heap)"""
    if dae.z.numel() <= SX_SOLVE_MAX:
        try:
            return _zero_rates(dae, ca.SX)
        except (RuntimeError, NotImplementedError, TypeError):
            pass
    return _zero_rates(dae, ca.MX)


def lie_rates(ode, alg, zero, args):
    """[g; ġ; g̈] of the zero functions at the symbols `args` (t, x, z, u, p, d), along the DAE given by
    its functions (ż from alg = 0, inputs held): the simulator's and the FMU wrapper's rules on a
    boundary read the same rates."""
    t, x, z = args[:3]
    f = ode(*args)
    w, field = x, f
    if z.numel():
        a = alg(*args)
        zdot = -ca.solve(ca.jacobian(a, z), ca.jacobian(a, x) @ f + ca.jacobian(a, t))
        w, field = ca.vertcat(x, z), ca.vertcat(f, zdot)

    def lie(e):
        return ca.jtimes(e, w, field) + ca.jacobian(e, t)

    g = zero(*args)
    gd = lie(g)
    return ca.densify(ca.vertcat(g, gd, lie(gd)))


def _zero_rates(dae, sym):
    args = [sym.sym(n, v.shape) for n, v in zip("txzupd", (dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))]
    g = dae.zero(*args)
    rates = lie_rates(dae.ode, dae.alg, dae.zero, args)
    noise = round_off(rates, args, dae.x_nominal, dae.z_nominal)
    m = g.numel()
    return (ca.Function("zero_rates", args, [rates]),
            ca.Function("zero_rates_noise", args, [ca.densify(ca.vertcat(rates, noise[:m]))]),
            ca.Function("zero_rates_round_off", args, [ca.densify(noise[m:])]))


def round_off(e, args, x_nominal, z_nominal):
    """How far e may sit from its value by the round-off of the states alone: a few ulps of each state at
    its scale, max(|x|, nominal), through |∂e/∂x| and |∂e/∂z| (`_at_rest`)."""
    x, z = args[1:3]
    eps = 4 * np.finfo(float).eps
    out = ca.mtimes(ca.fabs(ca.jacobian(e, x)), eps * ca.fmax(ca.fabs(x), ca.DM(x_nominal)))
    if z.numel():
        out = out + ca.mtimes(ca.fabs(ca.jacobian(e, z)), eps * ca.fmax(ca.fabs(z), ca.DM(z_nominal)))
    return out


def _cubic_extrema(g_a, d_a, g_b, d_b, h):
    """Times (in (0, h)) and values of the extrema of the cubic Hermite interpolant, per function.

    Returns arrays (n, 2) of times and values, NaN where there is none."""
    # p(s) = g_a + d_a s + c2 s² + c3 s³ on s ∈ [0, h] (an interval of length 0 has no extremum: NaN)
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = (3 * (g_b - g_a) / h - 2 * d_a - d_b) / h
        c3 = (2 * (g_a - g_b) / h + d_a + d_b) / h ** 2
    # p'(s) = d_a + 2 c2 s + 3 c3 s² = 0
    A, B, C = 3 * c3, 2 * c2, d_a
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = B * B - 4 * A * C
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        q = -0.5 * (B + np.copysign(root, B))
        s1, s2 = q / A, C / q
        linear = np.abs(A) <= 1e-14 * (np.abs(B) + np.abs(C) / h)
        s1 = np.where(linear, -C / B, s1)
        s2 = np.where(linear, np.nan, s2)
    s = np.stack([s1, s2], axis=-1)
    s = np.where((s > 0) & (s < np.asarray(h)[..., None]), s, np.nan)
    val = g_a[..., None] + s * (d_a[..., None] + s * (c2[..., None] + s * c3[..., None]))
    return s, val


def _allowed(dirs, before, after):
    """Which functions go from side `before` (±1, 0 unknown) to a value `after` across zero, in their
    direction: falling from + to ≤ 0, rising from − to ≥ 0 (`core.events.crosses`, on arrays)."""
    # from the boundary (side 0: resting on it with ġ = g̈ = 0) only a directional function crosses, by
    # leaving it into its direction, as `_crossing_now` decides for one that leaves it with a rate; a
    # "both" function leaving 0 has not changed sign
    return (((before > 0) & (after <= 0) & (dirs <= 0)) | ((before < 0) & (after >= 0) & (dirs >= 0))
            | ((before == 0) & (after != 0) & (dirs != 0) & (np.sign(after) == dirs)))


def _leaving(g, gd, noise, dirs):
    """g with the values within the round-off of the states (`noise`) of functions moving away from their
    direction put on the side they move to: no crossing. A contact leaving its boundary at s = 1024 m
    reads a gap of exactly 0 for its first 2e-13 m, and a cubic through those zeros with slope 1 dips
    below them; found as crossings, they fired impacts on a separating contact."""
    return np.where((np.abs(g) <= noise) & (dirs != 0) & (np.sign(gd) == -dirs), np.sign(gd) * 1e-300, g)


def _at_rest(g, gd, gdd, noise, horizon, rate_round_off):
    """(g, ġ, g̈, rest) with exact zeros for the functions at rest on their boundary: g within its
    round-off and each rate either within its own round-off or too small to move g out of g's within
    the run (|ġ|·T, |g̈|·T² ≤ g's round-off). `noise`: g's round-off; `rate_round_off()`: ġ's and g̈'s,
    asked only where g is within its own and the rates do not settle it. Such a function (two
    touching pendulums hanging at rest) has no side to be on: its round-off wandering across 0 is no
    crossing. Only round-off counts, never a tolerance: a slow closing that the integration resolves is
    an impact, however slow. Works on arrays of points (functions in the last axis)."""
    close = np.abs(g) <= noise
    slow_d, slow_dd = np.abs(gd) * horizon <= noise, np.abs(gdd) * horizon ** 2 <= noise
    rest = close & slow_d & slow_dd
    if np.any(close & ~rest):
        n_gd, n_gdd = rate_round_off()
        rest = close & (slow_d | (np.abs(gd) <= n_gd)) & (slow_dd | (np.abs(gdd) <= n_gdd))
    return np.where(rest, 0.0, g), np.where(rest, 0.0, gd), np.where(rest, 0.0, gdd), rest


def others_of(fired, m) -> np.ndarray:
    """True for the m functions that are not among `fired`."""
    others = np.ones(m, dtype=bool)
    others[list(fired)] = False
    return others


def _hermite_root(t_a, g_a, d_a, t_b, g_b, d_b):
    """The root in (t_a, t_b) of the cubic through (g_a, ġ_a) and (g_b, ġ_b), or None (no rates, or
    no sign change of the cubic inside). Bisection on the cubic then Newton polishing: cheap numbers."""
    if not (np.isfinite(d_a) and np.isfinite(d_b)) or np.sign(g_a) == np.sign(g_b):
        return None
    h = t_b - t_a

    def cubic(s):                                      # s in [0, 1]
        h00, h10, h01, h11 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s, -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        return h00 * g_a + h10 * h * d_a + h01 * g_b + h11 * h * d_b
    def slope(s):
        return (6 * s ** 2 - 6 * s) * (g_a - g_b) / h + (3 * s ** 2 - 4 * s + 1) * d_a + (3 * s ** 2 - 2 * s) * d_b
    a, b, fa = 0.0, 1.0, g_a
    s = g_a / (g_a - g_b)                              # Newton on the cubic from the secant point,
    for _ in range(40):                                # kept inside the shrinking sign-change bracket
        f = cubic(s)
        if f == 0.0:
            return t_a + s * h
        if np.sign(f) == np.sign(fa):
            a, fa = s, f
        else:
            b = s
        if b - a < 1e-15 or abs(f) <= 1e-15 * (abs(g_a) + abs(g_b)):
            break
        d = slope(s) * h
        step = s - f / d if d != 0.0 else 0.5 * (a + b)
        s = step if a < step < b else 0.5 * (a + b)
    return t_a + s * h


def _predicted(dirs, before, s, ext, g_b):
    """Which functions the Hermite cubic (extrema at times s, values ext, end value g_b) takes across
    zero in their direction, starting from side `before`: its knots walked in time order."""
    order = np.argsort(np.where(np.isnan(s), np.inf, s), axis=-1)
    ext = np.take_along_axis(ext, order, axis=-1)
    hit, prev = np.zeros(np.shape(g_b), dtype=bool), np.array(before, dtype=float)
    for v in (ext[..., 0], ext[..., 1], g_b):
        valid = ~np.isnan(v)
        hit |= valid & _allowed(dirs, prev, np.where(valid, v, 0.0))
        prev = np.where(valid & (np.nan_to_num(v) != 0), np.sign(np.nan_to_num(v)), prev)
    return hit


class StateEvents:
    """Mixin of the simulation loop (`run.Run`): everything about zero crossings."""

    _armed = None            # side of each zero function (±1; 0 on the boundary and not moving)
    _armed_at = None         # the time they were set at
    _pending = None          # the bracket found by _first_crossing, for _handle_event
    _resolution = ()         # (t, time resolution of each function's event there): `_time_resolution`
    _resting = None          # (T∞, cause) of a rest its events predicted beyond the last located one
    _offset = None           # per condition: the location error an event left it with, taken as its boundary

    def _rates(self, t, x, z, left=False):
        """g, ġ, g̈ at (t, x, z), exactly 0 where a function rests on its boundary within round-off
        (`_at_rest`); `left`: at a time event, the left limit of the inputs and signals."""
        return self._rates_and_round_off(t, x, z, left)[0]

    def _rates_and_round_off(self, t, x, z, left=False):
        """`_rates` and `_round_off` at one point, from one evaluation."""
        if left and t in getattr(self, "_time_event_times", ()):
            t = np.nextafter(t, -np.inf)
        rates = built(self.dae.info, "_zero_rates_numpy", lambda: NumpyCall(zero_rates_noise(self.dae)))
        out = rates(np.atleast_1d(float(t)), np.atleast_1d(np.asarray(x, dtype=float)),
                    np.atleast_1d(np.asarray(z, dtype=float)), np.atleast_1d(np.asarray(self._u_at(t), dtype=float)),
                    np.atleast_1d(self.p), np.atleast_1d(self.d))[0]
        g, gd, gdd, noise = np.asarray(out).ravel().reshape(4, -1)
        g = g - self._offset if self._offset is not None else g

        def rate_round_off():
            fn = built(self.dae.info, "_zero_rates_round_off_numpy", lambda: NumpyCall(zero_rates_round_off(self.dae)))
            return np.asarray(fn(*args)[0]).ravel().reshape(2, -1)
        args = (np.atleast_1d(float(t)), np.atleast_1d(np.asarray(x, dtype=float)),
                np.atleast_1d(np.asarray(z, dtype=float)), np.atleast_1d(np.asarray(self._u_at(t), dtype=float)),
                np.atleast_1d(self.p), np.atleast_1d(self.d))
        return np.stack(_at_rest(g, gd, gdd, noise, self._horizon(), rate_round_off)[:3]), noise

    def _horizon(self):
        """The run's length (s): how long a function at rest on its boundary must stay within round-off."""
        return getattr(self, "_run_span", 1.0)

    def _round_off(self, t, x, z):
        """How far each zero function may sit from its value by the round-off of the states alone (a few
        ulps of each state at its scale, max(|x|, nominal), through ∂g/∂x, ∂g/∂z): what it cannot
        resolve whatever the tolerance. At its scale, not its value: pendulums hanging at rest read
        angles of 1e-45 rad, the round-off of the scene's solve, and contacts between them saw those
        cross zero."""
        return self._rates_and_round_off(t, x, z)[1]

    def _left_of_time_events(self, pts):
        """A piece ending at a time event is judged by its conditions' left limits there (a clutch
        engaged by a step at 0.5 s makes a brake's condition jump *at* 0.5 s, which is no crossing
        before it); the jump itself is looked at by `_after_time_event`."""
        times = getattr(self, "_time_event_times", ())
        if not times or pts.size < 2 or pts[-1] not in times:
            return pts
        out = pts.copy()
        out[-1] = np.nextafter(pts[-1], -np.inf)
        return out

    def _after_time_event(self, t):
        """At a time event (inputs and signals jump, states do not): conditions the jump threw across,
        or set moving from their boundary, in their direction, fire at that instant; the others are
        re-armed on their new sides."""
        if not self.dae.zero_labels or self._armed is None:
            return
        sides, on, _ = self._sides(t, self._rates(t, self.x, self.z))
        dirs = np.array(self.dae.zero_directions)
        thrown = np.flatnonzero(_allowed(dirs, self._armed, sides) & ~on).tolist()
        # one on its boundary that the jump sets moving into its direction crosses now, as at the start
        # (masses touching at rest, one pushed into the other by a force stepping on)
        thrown += [i for i in self._crossing_now(sides, on) if self._armed[i] != sides[i] and i not in thrown]
        if thrown:
            self._fire(t, self.x, self.z, [int(h) for h in thrown], thrown=thrown)
        else:
            self._armed, self._armed_at = sides, t

    def _tol_t(self, t):
        return location_tolerance(t)

    def _sides(self, t, rates, near=None):
        """The side each function is on just after t (`core.events.side`, on arrays): the sign of g, or
        where g is on its boundary the sign of ġ, else of g̈. Returns (sides, on_boundary, moving_by_rate). `near`: after an event, how
        close to zero each function was found (a fired one is on its boundary unless its reset moved it
        away)."""
        g, gd, gdd = rates
        tol = self._tol_t(t)
        on = (g == 0) | (np.abs(g) <= np.abs(gd) * tol)
        if near is not None:
            on |= np.abs(g) <= near
        by_rate = np.abs(gd) > np.abs(gdd) * tol
        return np.where(on, np.where(by_rate, np.sign(gd), np.sign(gdd)), np.sign(g)), on, by_rate

    def _crossing_now(self, sides, on):
        """Directional functions on their boundary moving into their direction: they cross now."""
        dirs = np.array(self.dae.zero_directions)
        return [int(i) for i in np.flatnonzero(on & (dirs != 0) & (sides == dirs))]

    def _arm(self, t):
        """At the start of the run: arm every function; a directional one leaving its boundary in its
        direction fires at once. False when that stopped the run."""
        if not self.dae.zero_labels:
            return True
        sides, on, _ = self._sides(t, self._rates(t, self.x, self.z))
        self._armed, self._armed_at = sides, t
        now = self._crossing_now(sides, on)
        # a condition marked at_start that is already past zero in its direction fires now (a friction
        # element started stuck beyond its static limit breaks away at once)
        dirs = np.array(self.dae.zero_directions)
        at_start = np.array(self.dae.info.get("zero_at_start", ()) or [False] * len(sides), dtype=bool)
        now = sorted(set(now) | set(np.flatnonzero(at_start & ~on & (dirs != 0) & (sides == dirs)).tolist()))
        if now:
            self._fire(t, self.x, self.z, now)
        return self.failure is None

    def _zero_spacing(self, pts, xs, zs) -> float:
        """The widest monitor spacing (s) the zero functions' own rates allow on this piece: a function
        that changes faster than the states the solver resolves (sin φ of a flywheel winding many turns
        per solver step) would fit whole excursions between points spaced by solver steps alone. Each
        function may move by at most half its size on the piece per interval, to first and second
        order: Δ·|ġ| ≤ s/2 and Δ²·|g̈| ≤ s/4, s = max |g| on the piece (inf when no function moves)."""
        n = pts.size
        # the rates alone: their round-off (Jacobians of ġ and g̈) is not needed here
        rates = mapped_in(self.dae.info.setdefault("_zero_rate_value_maps", {}), zero_rates(self.dae), n)
        R = rates(pts.reshape(1, -1), xs.T, zs.T, self._inputs_at(pts), np.tile(self.p.reshape(-1, 1), n),
                  np.tile(self.d.reshape(-1, 1), n))[0]
        m = len(self.dae.zero_labels)
        G, D, A = np.abs(R[:m]), np.abs(R[m: 2 * m]), np.abs(R[2 * m: 3 * m])
        size = np.max(G, axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            first = np.where(D > 0, 0.5 * size / D, np.inf)
            second = np.where(A > 0, np.sqrt(0.25 * size / A), np.inf)
        allowed = np.minimum(first, second)
        allowed = allowed[np.isfinite(allowed) & (allowed > 0)]
        return float(np.min(allowed)) if allowed.size else np.inf

    def _first_crossing(self, pts, xs, zs, limit):
        """Index of the last monitor point before the first event among pts (up to `limit`), or None.

        Candidates: a sign change between points against the armed side, or an extremum of the
        Hermite cubic beyond zero; each is confirmed by re-integration (`_bracket`) and the bracket
        kept for `_handle_event`. On return without a crossing the functions are armed with their
        sides at the last point."""
        if not self.dae.zero_labels:
            return None
        n = pts.size if limit is None else limit + 1
        judged = self._left_of_time_events(pts[:n])      # inputs and signals at their left limits too
        U = self._inputs_at(judged)
        rates = mapped_in(self.dae.info.setdefault("_zero_rate_maps", {}), zero_rates_noise(self.dae), n)
        R = rates(judged.reshape(1, -1), xs[:n].T, zs[:n].T, U,
                  np.tile(self.p.reshape(-1, 1), n),
                  np.tile(self.d.reshape(-1, 1), n))[0]
        m = len(self.dae.zero_labels)
        dirs = np.array(self.dae.zero_directions)
        noise = R[3 * m:, 0]                            # the round-off of g at the piece's start

        def rate_round_off():
            fn = mapped_in(self.dae.info.setdefault("_zero_round_off_maps", {}), zero_rates_round_off(self.dae), n)
            Q = fn(judged.reshape(1, -1), xs[:n].T, zs[:n].T, U, np.tile(self.p.reshape(-1, 1), n),
                   np.tile(self.d.reshape(-1, 1), n))[0]
            return Q[:m].T, Q[m:].T
        G0 = R[:m] - self._offset[:, None] if self._offset is not None else R[:m]
        G, D, _, rest = _at_rest(G0.T, R[m: 2 * m].T, R[2 * m: 3 * m].T, R[3 * m:].T, self._horizon(),
                                 rate_round_off)  # (n, m)
        G = _leaving(G, D, noise, dirs)
        # the side at each point: its sign; at the start the armed side where it was set at that very time
        # (just after an event g may be a round-off on either side) or where g is exactly 0
        side = np.sign(G)
        keep = (side[0] == 0) | (self._armed_at == pts[0])
        side[0] = np.where(keep, self._armed if self._armed is not None else 0.0, side[0])
        last = np.maximum.accumulate(np.where(side != 0, np.arange(n)[:, None], 0), axis=0)
        side = np.take_along_axis(side, last, axis=0)
        # a function that comes to rest on its boundary stays on the side it was on: no crossing
        G = np.where(rest & (side != 0), side * 1e-300, G)
        h = np.diff(pts[:n])[:, None]
        s, ext = _cubic_extrema(G[:-1], D[:-1], G[1:], D[1:], h)
        ext = np.where(np.abs(ext) <= noise[:, None], np.nan, ext)     # (points, functions, 2)
        hit = _predicted(dirs, side[:-1], s, ext, G[1:])
        for j in np.flatnonzero(np.any(hit, axis=1)):
            try:
                found = self._bracket(pts[j], xs[j], zs[j], side[j], pts[j + 1], xs[j + 1], zs[j + 1])
            except EventSearchFailed as exc:
                self._search_failed(exc, pts[j], xs[j], zs[j])
                return int(j)                           # the result is kept up to there
            if found is not None:
                self._pending = found
                return int(j)
        self._armed, self._armed_at = side[n - 1], pts[n - 1]
        return None

    def _bracket(self, t_a, x_a, z_a, s_a, t_b, x_b, z_b, depth=0):
        """The earliest confirmed crossing in (t_a, t_b]: (functions, lo, x_lo, z_lo, s_lo, hi, x_hi, z_hi),
        where s_lo are the sides at lo; None when re-integration shows none (a grazing prediction)."""
        dirs = np.array(self.dae.zero_directions)
        (ra, noise), rb = self._rates_and_round_off(t_a, x_a, z_a), self._rates(t_b, x_b, z_b, left=True)
        ra[0], rb[0] = _leaving(ra[0], ra[1], noise, dirs), _leaving(rb[0], rb[1], noise, dirs)
        s, ext = _cubic_extrema(ra[0], ra[1], rb[0], rb[1], t_b - t_a)
        ext = np.where(np.abs(ext) <= noise[:, None], np.nan, ext)
        cand = _predicted(dirs, s_a, s, ext, rb[0])
        knots = sorted({t_a + float(v) for v in s[cand].ravel() if np.isfinite(v)})
        ts, states = [t_a], [(x_a, z_a)]
        for t in knots:
            ts.append(t)
            states.append(self._advance_to(t_a, x_a, z_a, t))
        ts.append(t_b)
        states.append((x_b, z_b))
        G = [ra[0]] + [_leaving(*self._rates(t, *st)[:2], noise, dirs) for t, st in zip(ts[1:-1], states[1:-1])] \
            + [rb[0]]
        side = s_a
        for k in range(1, len(ts)):
            crossed = np.flatnonzero(_allowed(dirs, side, G[k]))
            if crossed.size:
                x_lo, z_lo = states[k - 1]
                return (crossed, ts[k - 1], x_lo, z_lo, side, ts[k], *states[k])
            side = np.where(G[k] != 0, np.sign(G[k]), side)
        if depth < SPLIT_DEPTH and len(ts) > 2:        # the cubic was off: look again between the knots
            side = s_a
            for k in range(1, len(ts)):
                found = self._bracket(ts[k - 1], *states[k - 1], side, ts[k], *states[k], depth + 1)
                if found is not None:
                    return found
                side = np.where(G[k] != 0, np.sign(G[k]), side)
        return None

    def _advance_to(self, t_a, x_a, z_a, t):
        """The state at t integrated from (t_a, x_a, z_a), without the whole turns of periodic
        coordinates like every integrator call (`Run._turns`); raises EventSearchFailed."""
        ox, oz = self._turns(np.asarray(x_a, dtype=float), np.asarray(z_a, dtype=float))
        try:
            _, out = self._call(t_a, t - t_a, lambda: self.integrators.get((1.0,)), (x_a - ox) / self.xn,
                                (z_a - oz) / self.zn if self.zn.size else np.zeros(0), self.pvec(t_a, t - t_a))
        except RuntimeError as exc:
            raise EventSearchFailed(t_a, t, str(exc)) from None
        x = np.asarray(out["xf"]).ravel() * self.xn + ox
        z = np.asarray(out["zf"]).ravel() * self.zn + oz if self.zn.size else np.zeros(0)
        return x, z

    def _search_failed(self, exc, t_good, x_good, z_good):
        """Re-integration in the crossing search failed: the run stops with an IntegrationError after
        (t_good, x_good, z_good), its last good point (the result holds the solution up to there)."""
        solver = solver_message(str(exc))
        self.x, self.z = np.asarray(x_good, dtype=float).copy(), np.asarray(z_good, dtype=float).copy()
        self.failure = IntegrationError(
            f"integration failed between t = {exc.t_a:.6g} s and {exc.t:.6g} s while locating a state event; "
            f"solver: {solver}. The result holds the solution up to t = {t_good:.6g} s",
            t=float(t_good), step=float("nan"), worst="-", solver_message=solver)
        self.stats["failed_at"] = float(t_good)

    def _locate(self, i, lo, f_lo, hi, f_hi, t_a, x_a, z_a, x_hi, z_hi, d_lo=np.nan, d_hi=np.nan):
        """Function i's crossing on [lo, hi] (f_lo, f_hi of opposite sides; d_lo, d_hi its rates ġ
        there), states re-integrated from (t_a, x_a, z_a), to the location tolerance. Returns (t, x, z)
        at the end past the crossing.

        Each trial point is the root of the cubic Hermite interpolant of g and ġ on the bracket (exact
        for a ball's parabola; fourth order in the bracket width otherwise), pushed a quarter of the
        tolerance towards the bracket's farther end so that, once the prediction is good, the next
        point lands on the other side and closes the bracket: two to three re-integrations where
        Illinois regula falsi took about eight (each one an integrator restart from t_a). A trial that
        does not halve the bracket hands the next step to Illinois (or bisection), so the bracket
        always shrinks."""
        sign_lo = np.sign(f_lo)
        tol = self._tol_t(hi)
        side, slow = 0, False
        for _ in range(200):
            width = hi - lo
            if width <= tol:
                break
            t = None if slow else _hermite_root(lo, f_lo, d_lo, hi, f_hi, d_hi)
            if t is not None:
                t += 0.25 * tol * (1.0 if hi - t > t - lo else -1.0)
            elif f_hi != f_lo:
                t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
            if t is None or not (lo < t < hi):
                t = 0.5 * (lo + hi)
            x_t, z_t = self._advance_to(t_a, x_a, z_a, t)
            r_t = self._rates(t, x_t, z_t)
            g_t, d_t = r_t[0][i], r_t[1][i]
            if np.sign(g_t) != sign_lo:                   # the crossing lies in (lo, t]
                hi, f_hi, d_hi, x_hi, z_hi = t, g_t, d_t, x_t, z_t
                if side == -1:
                    f_lo *= 0.5                           # Illinois: the same end kept twice
                side = -1
            else:
                lo, f_lo, d_lo = t, g_t, d_t
                if side == 1:
                    f_hi *= 0.5
                side = 1
            slow = hi - lo > 0.5 * width
        return hi, x_hi, z_hi

    def _handle_event(self, t_a, x_a, z_a, t_b):
        """Locate the crossing bracketed by `_first_crossing` (the earliest of the functions crossing
        there), then apply the transition(s) and re-initialise."""
        crossed, lo, x_lo, z_lo, s_lo, hi, x_hi, z_hi = self._pending
        self._pending = None
        (g_lo, d_lo, _), (g_hi, d_hi, _) = self._rates(lo, x_lo, z_lo), self._rates(hi, x_hi, z_hi)
        best = None
        for i in crossed:
            # a start on the boundary has no sign yet: the armed side stands in for it
            f_lo = g_lo[i] if np.sign(g_lo[i]) == s_lo[i] else s_lo[i] * 1e-300
            if s_lo[i] == 0:
                f_lo = -np.sign(g_hi[i]) * 1e-300
            try:
                found = self._locate(i, lo, f_lo, hi, g_hi[i], lo, x_lo, z_lo, x_hi, z_hi,
                                     d_lo[i] if abs(f_lo) > 1e-300 else np.nan, d_hi[i])
            except EventSearchFailed as exc:
                self._search_failed(exc, t_a, x_a, z_a)
                return t_a
            if best is None or found[0] < best[0]:
                best = found
        t_e, x_e, z_e = best
        dirs = np.array(self.dae.zero_directions)
        # every function that crossed by t_e fires, in index order (two balls landing at once)
        fired = [int(h) for h in np.flatnonzero(_allowed(dirs, s_lo, self._rates(t_e, x_e, z_e)[0]))]
        self._record_at(t_e, x_e, z_e)
        self._fire(t_e, x_e, z_e, fired or [int(crossed[0])])
        return t_e

    def _fire(self, t_e, x_e, z_e, fired, thrown=()):
        """Apply the transitions of `fired` at t_e (the left limit is recorded already), record the
        right limit and re-arm. Conditions the resets make cross fire at the same instant, in rounds
        (event iteration); a round repeating an earlier one (the same functions from the same state:
        nothing would ever change) or more than MAX_CASCADE rounds is an accumulation: the run stops.

        The rows at t_e are the left and the right limit only: a round's row is replaced by the next
        round's, since its modes are those of neither side (a brake held by a mode about to change
        showed the torque it held). `thrown`: conditions a time event threw across (well past their
        zero); the row of that time event holds the new inputs with the old modes and is replaced too."""
        once, seen, thrown = set(), set(), set(thrown)
        replace = bool(thrown)
        dirs = np.array(self.dae.zero_directions)
        near = None
        for _ in range(MAX_CASCADE + 1):
            if not fired:
                return
            key = (tuple(fired), (np.asarray(x_e, dtype=float) + 0.0).tobytes(),   # + 0.0: −0.0 is 0.0
                   (self.d + 0.0).tobytes())
            if key in seen or len(seen) == MAX_CASCADE:
                why = ("its reset leaves the condition crossing, so it fires again at the same instant"
                       if key in seen else f"more than {MAX_CASCADE} rounds of firings at the same instant")
                self._accumulation(t_e, fired[0], why)
                return
            seen.add(key)
            once.update(fired)
            g_left, gd_left, gdd_left = self._rates(t_e, x_e, z_e)
            if not self._resolution or self._resolution[0] != t_e:
                self._resolution = (t_e, self._time_resolution(t_e, x_e, z_e, gd_left))
            before, _, _ = self._sides(t_e, (g_left, gd_left, gdd_left))
            # how close to its boundary each condition that crossed at this instant may sit and still count
            # as on it, kept over the rounds; none for one a reset threw across (it is well past its zero)
            near = np.zeros_like(g_left) if near is None else near
            crossed = [h for h in fired if h not in thrown]
            near[crossed] = np.maximum(near[crossed], 2 * np.maximum(np.abs(g_left[crossed]),
                                                                     np.abs(gd_left[crossed]) * self._tol_t(t_e)))
            x_now, d_now, u_e = np.asarray(x_e, dtype=float), self.d, self._u_at(t_e)
            for n_done, h in enumerate(fired):  # one after the other: each sees the resets before it
                if n_done and z_e.size:         # and the algebraic variables they leave (a loop's rates)
                    z_e = solve_algebraic(self.dae, t_e, x_now, z_e, u_e, self.p, d_now)
                x_plus, d_plus = self.dae.transition[h](t_e, x_now, z_e, u_e, self.p, d_now)
                x_now, d_now = np.asarray(x_plus, dtype=float).ravel(), np.asarray(d_plus, dtype=float).ravel()
            self.x, self.d = x_now, d_now
            self.z = z_e = solve_algebraic(self.dae, t_e, self.x, z_e, u_e, self.p, self.d)
            x_e = self.x
            self._record_right_limit(t_e, replace)
            replace = True
            for h in fired:
                self.events.append(Event(float(t_e), "state", self.dae.zero_labels[h]))
            rates_now = self._rates(t_e, self.x, self.z)
            sides, on, by_rate = self._sides(t_e, rates_now, near)
            sides = self._settled(t_e, rates_now, sides, on, before, dirs, others_of(fired, len(sides)))
            self._keep_location_error(rates_now[0], sides, near, fired)
            self._armed, self._armed_at = sides, t_e
            # one that fired and goes on across with speed has completed its crossing (a sensor);
            # one held on its boundary by g̈ alone cannot leave it (a ball at rest): it fires again;
            # one the resets threw across to its other side, in its direction, crossed (a cascade)
            now = set(self._crossing_now(sides, on))
            others = np.ones(len(sides), dtype=bool)
            others[fired] = False
            jumped = others & ~on & _allowed(dirs, before, sides) & (before != 0)
            thrown = set(np.flatnonzero(jumped).tolist())
            fired = sorted({h for h in now if not (h in once and by_rate[h])} | set(np.flatnonzero(jumped).tolist()))
        self._accumulation(t_e, fired[0], f"more than {MAX_CASCADE} rounds of firings at the same instant")

    def _keep_location_error(self, g, sides, near, fired):
        """After a round of resets, a condition left within what its event was located to (`near`) on the
        other side of the side it is armed on keeps that value as its boundary until it fires again: the
        location error is not a crossing, however long it takes to leave it. After a cradle's return cascade
        the last stop read a gap of −6.7e-15 rad (the impact's location error), armed on + (the balls' weight
        pulls it back, at 2.6e-13 rad/s², so it stays below 0 for 0.23 s): the next monitor point read a
        crossing, the stop fired again 9e-14 s later, the two events were taken for an accumulation, and the
        rest it ended in (a plastic jump) later glued two balls together and halved the swing energy. The
        shift is at most the location error (~1e-12 of the condition's scale)."""
        off = np.zeros_like(g) if self._offset is None else self._offset.copy()
        off[list(fired)] = 0.0
        wrong = (near > 0) & (np.abs(g) <= near) & (sides != 0) & (np.sign(g) == -sides)
        off = np.where(wrong, off + g, off)
        self._offset = off if np.any(off) else None

    def _settled(self, t, rates, sides, on, before, dirs, others):
        """`sides` with the conditions a reset switched on just beyond their boundary put back on the side
        they were on: within what the integration resolves of g there, and moving back to that side.
        Their sign is an earlier event's location error, not a crossing: a body that came to rest on a
        contact sits ~1e-14 m inside it, and when the contact lets go its condition (a constant while
        resting) becomes that gap; read as a new impact, it put the body back to rest and held it in
        tension for the rest of the run."""
        g, gd, gdd = rates
        candidates = others & ~on & _allowed(dirs, before, sides) & (before != 0)
        if not candidates.any():
            return sides
        moving = np.where(np.abs(gd) > np.abs(gdd) * self._tol_t(t), np.sign(gd), np.sign(gdd))
        settle = candidates & (np.abs(g) <= self._resolved(t, self.x, self.z)) & (moving == before)
        return np.where(settle, before, sides)

    def _accumulation(self, t, i, why, t_inf=None):
        """Events of condition i accumulate at t: end them through its rest transition (a plastic jump
        and the rest modes: a ball comes to rest and the run goes on), or stop the run. `t_inf`: the
        accumulation time its events predict; the rest event is stamped there (`_rest_at_accumulation`)."""
        label = self.dae.zero_labels[i]
        rests = self.dae.info.get("rest_transition", ())
        if i < len(rests) and rests[i] is not None:
            u_t = self._u_at(t)
            x_plus, d_plus = rests[i](t, self.x, self.z, u_t, self.p, self.d)
            self.x, self.d = np.asarray(x_plus, dtype=float).ravel(), np.asarray(d_plus, dtype=float).ravel()
            self.z = solve_algebraic(self.dae, t, self.x, self.z, u_t, self.p, self.d)
            self._record_right_limit(t, True)
            self._armed, _, _ = self._sides(t, self._rates(t, self.x, self.z))
            self._armed_at = t
            if t_inf is not None and t_inf > t:
                self._resting = (t_inf, f"{label} — {why}")
            else:
                self.events.append(Event(float(t), "rest", f"{label} — {why}"))
            return
        times = [e.t for e in self.events if e.kind == "state" and e.cause == label][-4:]
        self.failure = IntegrationError(
            f"event accumulation at t = {t:.9g} s: {label} — {why} (chattering or a Zeno point such as a "
            f"bouncing ball coming to rest; its last events at t = {', '.join(f'{v:.9g}' for v in times)} s; "
            f"a stop or contact with a rest mode would come to rest here); the result holds the solution up "
            f"to there",
            t=float(t), step=float("nan"), worst=label, solver_message="event accumulation")

    def _record_right_limit(self, t, replace):
        """Record the state after a round of firings at t, in place of the last row when that row (at t)
        is a state on neither side of the instant."""
        if replace and len(self.rows) > 1 and self.rows.last.t == t:
            self.rows.drop_last()
        self._record(t)

    def _record_at(self, t, x, z):
        self.x, self.z = np.asarray(x, dtype=float).copy(), np.asarray(z, dtype=float).copy()
        self._record(t)

    def _time_resolution(self, t, x, z, gd):
        """How precisely the integration fixes the time of each function's event at (t, x, z): the error
        the tolerances allow in g (`_resolved`) over the speed |ġ| at which g crosses; never below the
        location tolerance."""
        with np.errstate(divide="ignore", invalid="ignore"):
            dt = self._resolved(t, x, z) / np.abs(gd)
        return np.maximum(np.nan_to_num(dt, nan=0.0, posinf=np.inf), self._tol_t(t))

    def _resolved(self, t, x, z):
        """The error the tolerances allow in each zero function's value at (t, x, z): rtol·|x| + atol·x_n
        in x and z, carried into g (∂g/∂x, ∂g/∂z)."""
        rtol, atol = self.settings[2], self.settings[3]
        x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
        sensitivity = built(self.dae.info, "_zero_sensitivity_numpy", lambda: NumpyCall(zero_sensitivity(self.dae)))
        jx, jz = sensitivity(np.atleast_1d(float(t)), np.atleast_1d(x), np.atleast_1d(z),
                             np.atleast_1d(np.asarray(self._u_at(t), dtype=float)), np.atleast_1d(self.p),
                             np.atleast_1d(self.d))
        dg = np.abs(np.asarray(jx)) @ (rtol * np.abs(x) + atol * self.xn)
        if z.size:
            dg = dg + np.abs(np.asarray(jz)) @ (rtol * np.abs(z) + atol * self.zn)
        return np.asarray(dg).ravel()

    def _check_accumulation(self):
        """Stop the run at a Zeno point, judged from the events of the condition that fired last: its
        last gap within ACCUMULATION_RESOLUTION location tolerances, or its last three gaps shrinking by
        a consistent ratio r < 1 that puts the accumulation point T∞ = t + gap·r/(1 − r) within
        ACCUMULATION_RESOLUTION time resolutions of its last event (`_time_resolution`: the events still
        to come are closer than the integration fixes them). The output grid plays no part."""
        if not self.events or self.events[-1].kind != "state":
            return
        cause = self.events[-1].cause
        times = np.array(sorted({e.t for e in self.events if e.kind == "state" and e.cause == cause}))
        if times.size < 2:
            return
        t = times[-1]
        label = self.dae.zero_labels.index(cause) if cause in self.dae.zero_labels else 0
        gaps = np.diff(times[-4:])
        if gaps[-1] <= ACCUMULATION_RESOLUTION * self._tol_t(t):
            self._accumulation(t, label, f"its events are {gaps[-1]:.3g} s apart, below what their location "
                                         f"resolves")
            return
        t_inf = accumulation_time(times)
        if t_inf is not None:
            remaining = t_inf - t
            r = gaps[2] / gaps[1]
            resolution = self._resolution[1][label] if self._resolution and self._resolution[0] == t \
                else self._tol_t(t)
            if remaining <= ACCUMULATION_RESOLUTION * resolution:
                # the best-resolved window's T∞ where it agrees with the last one's within a few last gaps (a
                # window from another stretch of the series predicted a cradle's round-off events 58 s on)
                best = best_accumulation_time(self._series(cause, times))
                if best is not None and abs(best - t_inf) <= ACCUMULATION_RESOLUTION * gaps[-1]:
                    t_inf = best
                # held to T∞ only over a few of its last gaps (r ≤ 10/11): a slow series (a cradle's round-off
                # events, r = 0.996, T∞ 31 s on) is no bouncing that ends there
                hold = t_inf if t_inf - t <= ACCUMULATION_RESOLUTION * gaps[-1] else None
                self._accumulation(t, label, f"its events come ever closer (gaps shrinking by {r:.3g}), "
                                             f"accumulating at {t_inf:.9g} s, {t_inf - t:.3g} s after the last "
                                             f"located one, within what the integration resolves of "
                                             f"their times ({resolution:.3g} s)", t_inf=hold)

    def _series(self, cause, times):
        """The times of the events of `cause` since it last came to rest (the series now accumulating)."""
        rests = [e.t for e in self.events if e.kind == "rest" and e.cause.startswith(f"{cause} — ")]
        return [v for v in times if not rests or v > rests[-1]]

    def _rest_at_accumulation(self, t, grid, event_at):
        """Where the run goes on after a rest its events predicted at T∞ (`_accumulation`): the rest modes
        hold from t, the last located event (what is left of the series rises less than the bounce after it,
        v²/2|g̈|, below what the integration resolves), and the rest event is stamped at T∞, where the
        bouncing ends: located impacts stop 5.8e-5 s short of it at rtol 1e-8, and T∞ = t + gap·r/(1 − r)
        is where the series lands. The run is carried to T∞ in the rest modes (and through the output times
        before it) and goes on from there. The hold is short: T∞ is within ACCUMULATION_RESOLUTION last gaps
        of the series after t (`_check_accumulation`). And it passes nothing
        over: with a time event or the run's end in (t, T∞], or a condition found crossed at an output time
        or at T∞, the rest stays at t. Returns the time the run goes on from."""
        t_inf, cause = self._resting
        self._resting = None
        inside = [float(g) for g in grid if t < g < t_inf]
        if t_inf >= grid[-1] or any(t < te <= t_inf for te in event_at):
            self.events.append(Event(float(t), "rest", cause))
            return t
        x0, z0 = self.x.copy(), self.z.copy()
        try:
            states = [self._advance_to(t, x0, z0, g) for g in (*inside, t_inf)]
        except EventSearchFailed:
            self.events.append(Event(float(t), "rest", cause))
            return t
        dirs = np.array(self.dae.zero_directions)
        for g, (x, z) in zip((*inside, t_inf), states):     # the hold is short: a few points at most
            if np.any(_allowed(dirs, self._armed, self._sides(g, self._rates(g, x, z))[0])):
                self.events.append(Event(float(t), "rest", cause))
                return t
        for g, (x, z) in zip((*inside, t_inf), states):
            self.x, self.z = x, z
            self._record(g)
        self.events.append(Event(float(t_inf), "rest", cause))
        self._armed, _, _ = self._sides(t_inf, self._rates(t_inf, self.x, self.z))
        self._armed_at = t_inf
        return t_inf
