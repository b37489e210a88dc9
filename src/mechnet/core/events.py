"""The rules of mechnet's events, stated once: what side a condition is on, what counts as its crossing,
and when a run of impacts has come to rest.

Every rule here is implemented twice, by necessity: by the simulator (`simulate/state_events.py`, on
arrays, in numpy) and by the FMU wrapper (`export/mechnet_fmu.c`, in C, with no Python at hand). Both
follow these functions, and both are tested against one table of cases (`tests/hard/test_event_rules.py`):
the functions here say what the answer is, the cases check each implementation gives it.

A condition g of a `When` is *armed* with a side, +1 or −1 (0: resting on its boundary, not moving).

- **Its side** is the sign of g; on its boundary (g = 0, or within what one location step moves it) it is
  the side g moves to: the sign of ġ, else of g̈ (`side`). Never the sign of a value sitting on the
  boundary: a ball landed exactly on the floor and thrown back up by its impact is above it.
- **A crossing** is a change of side in the condition's direction (`crosses`): falling from + to −
  or onto 0, rising from − to + or onto 0; "both" either way. From side 0 only a directional condition
  crosses, by leaving its boundary into its direction. Judged by sides, it fires only onto a side
  (`fires`): coming to rest on its boundary is no crossing.
- **After a reset**, the fired condition takes the side the reset leaves it on (`side` again). One the
  reset leaves on its boundary held there by g̈ alone (ġ = 0, g̈ pushing it across) crosses again at the
  same instant (`fires_again`): repeated from the same state, that is an accumulation, and the condition's
  rest transition ends it (a ball at rest).
- **Under fixed steps** (an FMU importer that sees events only at its steps' ends), the transition applies
  where the condition crossed within the step (`crossed_ago`), and a rebound whose impact takes less speed
  than the step's error adds back rests (`rests_under_fixed_steps`).
- **Accumulation**: the events of one condition whose last three gaps shrink by a consistent ratio
  r < 1 accumulate at T∞ = t + gap·r/(1 − r) (`accumulation_time`); when what remains is shorter than
  what the integration can resolve, the rest transition ends them (`rests`), and the simulator stamps the
  rest at T∞ as its best-resolved events predict it (`best_accumulation_time`).
"""
from __future__ import annotations

import math

RISING, FALLING, BOTH = 1, -1, 0
GEOMETRIC_SPREAD = 0.1   # relative spread of the last two gap ratios for a geometric accumulation


def location_tolerance(t: float) -> float:
    """How finely an event's time is located (s): 1e-12 relative, at least 1e-12 s."""
    return 1e-12 * max(1.0, abs(t))


def side(g: float, gd: float, gdd: float, t: float) -> tuple[int, bool, bool]:
    """(side, on its boundary, moving by its rate): the sign of g; on the boundary (g = 0, or within what
    the location tolerance moves it at speed ġ) the sign of ġ when ġ moves it further than g̈ does over
    that tolerance, else of g̈; 0 when it rests there (g = ġ = g̈ = 0)."""
    tol = location_tolerance(t)
    on = g == 0 or abs(g) <= abs(gd) * tol
    by_rate = abs(gd) > abs(gdd) * tol
    if not on:
        return _sign(g), False, by_rate
    return (_sign(gd) if by_rate else _sign(gdd)), True, by_rate


def crosses(direction: int, before: int, after: float) -> bool:
    """Does a condition armed on side `before` (±1, 0 resting on its boundary) cross by reaching `after`
    (a value or a side): falling from + to ≤ 0, rising from − to ≥ 0, in its direction; from its boundary
    only a directional one crosses, by leaving it into its direction."""
    if before > 0:
        return after <= 0 and direction <= 0
    if before < 0:
        return after >= 0 and direction >= 0
    return after != 0 and direction != 0 and _sign(after) == direction


def fires(direction: int, before: int, side_now: int) -> bool:
    """Does a condition armed on `before` fire on reaching side `side_now` (`side`): a crossing onto a
    side. One that comes to rest on its boundary (side 0) has not crossed: after a cradle's impact two
    pendulums are left touching at rest, and their contact does not strike again."""
    return side_now != 0 and crosses(direction, before, side_now)


def fires_again(direction: int, after: tuple[int, bool, bool]) -> bool:
    """A condition that just fired, and whose reset leaves it (`side` after the reset) on its boundary
    held into its direction by g̈ alone: it crosses again at once (a ball resting on the floor, whose
    reset v → −e·0 changes nothing). One that goes on across with speed has completed its crossing (a
    sensor), one thrown back has left."""
    s, on, by_rate = after
    return on and not by_rate and direction != 0 and s == direction


def accumulation_time(times) -> float | None:
    """T∞ of events at `times` (increasing) whose last three gaps shrink by a consistent ratio r < 1:
    t + gap·r/(1 − r); None when they do not (fewer than four events, gaps that grow or wander)."""
    times = list(times)[-4:]
    if len(times) < 4:
        return None
    gaps = [b - a for a, b in zip(times, times[1:])]
    if min(gaps) <= 0:
        return None
    r1, r2 = gaps[1] / gaps[0], gaps[2] / gaps[1]
    r = max(r1, r2)
    if not (r < 1 and abs(r2 - r1) <= GEOMETRIC_SPREAD * r):
        return None
    return times[-1] + gaps[-1] * r / (1 - r)


def best_accumulation_time(times) -> float | None:
    """T∞ of a series of events, predicted from its window of four consecutive events whose two gap ratios
    agree best (`accumulation_time` of each), and never before its last event; None when no window is
    geometric. The last events of a series are the worst resolved: at rtol 1e-8 a ball's 50th impact is
    1.7e-5 s off its series and the last window's ratio reads 0.745 for 0.8, putting T∞ 3.5e-5 s early,
    where its 15th predicts it to 1e-7 s."""
    times = list(times)
    best, spread = None, math.inf
    for k in range(len(times) - 3):
        window = times[k: k + 4]
        t_inf = accumulation_time(window)
        if t_inf is None or t_inf < times[-1]:
            continue
        gaps = [b - a for a, b in zip(window, window[1:])]
        r1, r2 = gaps[1] / gaps[0], gaps[2] / gaps[1]
        if abs(r2 - r1) / r2 < spread:
            best, spread = t_inf, abs(r2 - r1) / r2
    return best


def rests(times, resolution: float) -> bool:
    """Do the events at `times` accumulate within `resolution` (s) of the last: the events still to come
    are closer together than the integration fixes them, so the condition's rest transition ends them."""
    t_inf = accumulation_time(times)
    return t_inf is not None and t_inf - list(times)[-1] <= resolution


def flight_time(gd: float, gdd: float) -> float:
    """How long a condition leaving its boundary at rate ġ, pulled back at a constant g̈ of the other
    sign, stays off it: 2|ġ|/|g̈| (inf when g̈ does not pull it back). An FMU whose importer steps by h
    cannot see a flight shorter than h: such a rebound rests."""
    if gd == 0 or gdd == 0 or _sign(gd) == _sign(gdd):
        return math.inf
    return 2 * abs(gd) / abs(gdd)


FIXED_STEP_GAIN = 5.0      # |g̈|·h: the speed a fixed (Euler) step's error adds back over a flight (~4)
FIXED_STEP_FLIGHT = 50.0   # steps of a rebound's flight up to which that error matters


def rests_under_fixed_steps(gd_before: float, gd_after: float, gdd: float, h: float) -> bool:
    """Under an importer's fixed step h (one that does not locate events: it sees them at a step's end),
    an impact whose rebound takes less speed (|ġ| before less after) than the step's error adds back over
    a flight of a few dozen steps never decays: Euler's bouncing ball settles into bounces of constant
    height. Such a rebound rests (the FMU wrapper; the simulator locates every event). One that keeps its
    speed (e = 1) never does: there nothing is lost for the step's error to undo."""
    loss = abs(gd_before) - abs(gd_after)
    return (1e-12 * abs(gd_before) < loss <= FIXED_STEP_GAIN * abs(gdd) * h
            and flight_time(gd_after, gdd) <= FIXED_STEP_FLIGHT * h)


def crossed_ago(g: float, gd: float, h: float) -> float:
    """How long before the end of a fixed step h a condition found there past its boundary (g, moving on at
    ġ) crossed it: g/ġ, linear interpolation, at most h; 0 when ġ does not carry it that way. An FMU whose
    importer steps over a crossing takes the event there (every state carried back along its derivatives,
    the event iteration run at that instant) and carries the result on to the step's end: read at the
    step's end, friction sliding through v = 0 is up to |a|·h past it, far above v_small, and counts as
    thrown across instead of sticking."""
    if gd == 0 or _sign(g) != _sign(gd):
        return 0.0
    return min(g / gd, h)


def _sign(v: float) -> int:
    return (v > 0) - (v < 0)
