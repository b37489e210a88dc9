/* mechnet's FMI wrapper: Model Exchange for FMI 2.0 (FMI_VERSION 2) and 3.0 (FMI_VERSION 3).
 *
 * Written for mechnet from the FMI standard's function definitions. It calls the
 * functions CasADi generated from the compiled model's contract (model.c, see
 * mechnet.export.contract) through the tables in model_data.h:
 *   init       consistent start from the start values (a damped Newton, generated)
 *   solve_alg  the loop equations alg = 0 for z, warm-started from the last accepted z
 *   ode, observed, zero, transition_k, forward (directional derivatives), alg_jac (branch and conditioning)
 *   zero_rates [g; dg/dt; d2g/dt2] along the model, rest_k (the plastic jump ending an accumulation)
 * The event rules are mechnet's (mechnet/core/events.py), kept here as the simulator keeps them.
 * Nothing here depends on the model: model_data.h says what the value references are.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <stdbool.h>
#include "model_data.h"

#define EXPORT __attribute__((visibility("default")))
#define MN_MAX_EVENT_ROUNDS 100 /* discrete-state updates at one time before the events count as chattering */
#define MN_QUALITY_MIN 1e-3     /* conditioning below which the dependent coordinates count as singular */
#define MN_FIXED_STEP_GAIN 5.0  /* |d2g/dt2|·h: speed a fixed step's error adds per flight (Euler: ~4) */
#define MN_FIXED_STEP_FLIGHT 50.0   /* steps of a rebound's flight up to which that error matters */

typedef int (*mn_eval_t)(const casadi_real**, casadi_real**, casadi_int*, casadi_real*, int);
typedef int (*mn_work_t)(casadi_int*, casadi_int*, casadi_int*, casadi_int*);
typedef int (*mn_checkout_t)(void);
typedef void (*mn_release_t)(int);
typedef struct { mn_eval_t eval; mn_work_t work; mn_checkout_t checkout; mn_release_t release; } mn_function;

enum { ST_OK = 0, ST_WARNING = 1, ST_DISCARD = 2, ST_ERROR = 3, ST_FATAL = 4 };
enum { MODE_INSTANTIATED, MODE_INIT, MODE_EVENT, MODE_CONTINUOUS, MODE_TERMINATED };

#define TABLE(name) { MN_PREFIXED(name), MN_PREFIXED(name##_work), MN_PREFIXED(name##_checkout), MN_PREFIXED(name##_release) }
enum { F_INIT, F_SOLVE_ALG, F_ODE, F_OBSERVED, F_ZERO, F_ZERO_RATES, F_FORWARD, F_ALG_JAC, F_COUNT };
static const mn_function mn_functions[F_COUNT] = {
    TABLE(init), TABLE(solve_alg), TABLE(ode), TABLE(observed), TABLE(zero), TABLE(zero_rates), TABLE(forward),
    TABLE(alg_jac)};
static const mn_function mn_transitions[MN_NT + 1] = MN_TRANSITIONS;
static const mn_function mn_rests[MN_NT + 1] = MN_RESTS;     /* eval 0 where a condition has no rest */
#define N_CALLED (F_COUNT + 2 * MN_NT)

/* the k-th function the wrapper calls: the contract's, then the transitions, then the rests (or 0) */
static const mn_function *called(int k) {
    if (k < F_COUNT) return &mn_functions[k];
    if (k < F_COUNT + MN_NT) return &mn_transitions[k - F_COUNT];
    return mn_rests[k - F_COUNT - MN_NT].eval ? &mn_rests[k - F_COUNT - MN_NT] : 0;
}

typedef struct {
    char *name;
    void *environment;
    void *logger;                   /* fmi2CallbackLogger or fmi3LogMessageCallback */
    int logging;
    int mode;
    double t;
    double x[MN_NX + 1], xdot[MN_NX + 1], z[MN_NZ + 1], z_accepted[MN_NZ + 1];
    double u[MN_NU + 1], p[MN_NP + 1], d[MN_ND + 1], s[MN_NS + 1];
    double y[MN_NY + 1], g[MN_NG + 1], armed[MN_NG + 1];
    double rates[6 * MN_NG + 1];                /* [g; dg/dt; d2g/dt2; their round-off] here, when asked */
    int event_rounds;                           /* discrete-state updates since the event mode began */
    unsigned char fired_now[MN_NG + 1];         /* conditions fired since the event mode began */
    double near[MN_NG + 1];                     /* how far from 0 each counts as on its boundary at this instant */
    double event_times[MN_NG + 1][4];           /* each condition's last four event times, newest last */
    int n_event_times[MN_NG + 1];
    double t_step, h_step;                      /* the last completed integrator step: its end and length */
    int stepped_over;                           /* this event was seen at a step's end, not located: fixed steps */
    double carried_back;                        /* s: this event is taken that long before the importer's time */
    int need_z, need_xdot, need_y, need_g, need_rates, need_init;
    int branch_sign;                /* sign of det(d alg / d z) on the assembly branch of the start */
    int mem[N_CALLED + 1];
    const casadi_real **arg;
    casadi_real **res;
    casadi_int *iw;
    casadi_real *w;
    double jac[MN_NZ * (MN_NX + MN_NZ) + 1];
} Instance;

static void deliver(Instance *m, int status, const char *category, const char *text);   /* per FMI version */

/* a message to the importer's logger: errors always, the rest when debug logging is on */
static void logf_(Instance *m, int status, const char *category, const char *fmt, ...) {
    char text[1024];
    va_list ap;
    if (!m->logger || (!m->logging && status < ST_WARNING)) return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    deliver(m, status, category, text);
}

static int mn_call(Instance *m, mn_eval_t eval, int mem, const double **in, int n_in, double **out, int n_out) {
    int i;
    for (i = 0; i < n_in; i++) m->arg[i] = in[i];
    for (i = 0; i < n_out; i++) m->res[i] = out[i];
    return eval(m->arg, m->res, m->iw, m->w, mem);
}

static int call(Instance *m, int f, const double **in, int n_in, double **out, int n_out) {
    return mn_call(m, mn_functions[f].eval, m->mem[f], in, n_in, out, n_out);
}

static double inf_norm(const double *v, int n) {
    double a = 0;
    int i;
    for (i = 0; i < n; i++) a = fabs(v[i]) > a ? fabs(v[i]) : a;
    return a;
}

/* the sign of det(J) (n x n, column-major, overwritten) by LU with partial pivoting, 0 if singular;
 * *scale is multiplied by |det(J)| */
static int det_sign_abs(double *J, int n, double *scale) {
    int sign = 1, i, j, k;
    for (k = 0; k < n; k++) {
        int piv = k;
        for (i = k + 1; i < n; i++) if (fabs(J[i + k * n]) > fabs(J[piv + k * n])) piv = i;
        if (J[piv + k * n] == 0.0) { *scale = 0.0; return 0; }
        if (piv != k) {
            for (j = 0; j < n; j++) { double tmp = J[k + j * n]; J[k + j * n] = J[piv + j * n]; J[piv + j * n] = tmp; }
            sign = -sign;
        }
        if (J[k + k * n] < 0) sign = -sign;
        *scale *= fabs(J[k + k * n]);
        for (i = k + 1; i < n; i++) {
            double f = J[i + k * n] / J[k + k * n];
            for (j = k + 1; j < n; j++) J[i + j * n] -= f * J[k + j * n];
        }
    }
    return sign;
}

/* the sign of det(d alg/d z) (which assembly branch) and the conditioning of the choice of states:
 * |det(d alg/d z)| over the product of the norms of the rows of d alg/d(x, z) (Hadamard's ratio, in
 * [0, 1]), 0 where the dependent coordinates stop being functions of the states */
static int branch_of(Instance *m, double *quality) {
    const double *in[6] = {&m->t, m->x, m->z, m->u, m->p, m->d};
    double *out[1] = {m->jac};
    double q = 1.0;
    int i, j, sign;
    *quality = 1.0;
    if (MN_NZ == 0) return 1;
    call(m, F_ALG_JAC, in, 6, out, 1);
    for (i = 0; i < MN_NZ; i++) {
        double row = 0;
        for (j = 0; j < MN_NX + MN_NZ; j++) row += m->jac[i + j * MN_NZ] * m->jac[i + j * MN_NZ];
        q /= sqrt(row) > 0 ? sqrt(row) : 1.0;
    }
    sign = det_sign_abs(m->jac + MN_NX * MN_NZ, MN_NZ, &q);
    *quality = q;
    return sign;
}

/* z from the loop equations at (t, x), warm-started from the last accepted z */
static int ensure_z(Instance *m) {
    double norm, quality;
    int sign;
    if (!m->need_z) return ST_OK;
    if (MN_NZ > 0) {
        const double *in[6] = {&m->t, m->x, m->z_accepted, m->u, m->p, m->d};
        double *out[2] = {m->z, &norm};
        call(m, F_SOLVE_ALG, in, 6, out, 2);
        if (!(norm <= 1e-8 * (1.0 + inf_norm(m->z, MN_NZ)))) {
            logf_(m, ST_ERROR, "logStatusError", "t = %.17g: the loop equations have no solution near the last "
                  "accepted point (residual %.3g after the damped Newton); the mechanism cannot be assembled there",
                  m->t, norm);
            return ST_ERROR;
        }
        sign = branch_of(m, &quality);
        if (quality < MN_QUALITY_MIN) {
            logf_(m, ST_ERROR, "logStatusError", "t = %.17g: the loop's dependent coordinates are no longer "
                  "functions of the states %s (conditioning %.2g < %.2g: a singular position of the mechanism); "
                  "mechnet's simulator re-selects states here, the FMU keeps its one choice", m->t, MN_STATES,
                  quality, MN_QUALITY_MIN);
            return ST_ERROR;
        }
        if (sign != m->branch_sign) {
            logf_(m, ST_ERROR, "logStatusError", "t = %.17g: the solution of the loop equations changed assembly "
                  "branch (det d alg/d z changed sign from %d to %d): the exported choice of states %s cannot "
                  "continue here; mechnet's simulator re-selects states at such points, an FMU does not",
                  m->t, m->branch_sign, sign, MN_STATES);
            return ST_ERROR;
        }
    }
    m->need_z = 0;
    return ST_OK;
}

static int ensure_init(Instance *m);

static int ensure(Instance *m, int *need, int f, double *target) {
    int st;
    const double *in[6] = {&m->t, m->x, m->z, m->u, m->p, m->d};
    double *out[1] = {target};
    if ((st = ensure_init(m)) != ST_OK) return st;
    if (!*need) return ST_OK;
    if ((st = ensure_z(m)) != ST_OK) return st;
    call(m, f, in, 6, out, 1);
    *need = 0;
    return ST_OK;
}

static void changed(Instance *m) { m->need_z = m->need_xdot = m->need_y = m->need_g = m->need_rates = 1; }

static int initialize(Instance *m) {
    double w0[MN_NX + MN_NZ + 1], norm;
    const double *in[6] = {&m->t, m->u, m->p, m->d, m->s, w0};
    double *out[3] = {m->x, m->z, &norm};
    int i;
    for (i = 0; i < MN_NX + MN_NZ; i++) w0[i] = mn_guess[i];
    call(m, F_INIT, in, 6, out, 3);
    if (!(norm <= 1e-8 * (1.0 + fmax(inf_norm(m->x, MN_NX), inf_norm(m->z, MN_NZ))))) {
        logf_(m, ST_ERROR, "logStatusError", "consistent initialisation failed: residual %.3g after the damped "
              "Newton from the start values; check the start values and parameters", norm);
        return ST_ERROR;
    }
    for (i = 0; i < MN_NZ; i++) m->z_accepted[i] = m->z[i];
    m->branch_sign = branch_of(m, &norm);
    m->need_init = 0;
    m->need_z = 0;
    m->need_xdot = m->need_y = m->need_g = m->need_rates = 1;
    return ST_OK;
}

static int ensure_init(Instance *m) {
    if (m->need_init && (m->mode == MODE_INIT || m->mode == MODE_INSTANTIATED)) return initialize(m);
    return ST_OK;
}

/* ---------------------------------------------------------------- the event rules (mechnet/core/events.py)
 * A condition is armed with a side, +1 or -1 (0: resting on its boundary). Its side is the sign of g; on
 * its boundary, the side its rate dg/dt moves it to, else d2g/dt2: never the sign of a value sitting on
 * the boundary (a ball landed exactly on the floor and thrown back up is above it). A crossing is a change
 * of side in the condition's direction. Sides are taken at every completed integrator step, at the end of
 * every event update and after every reset, so no importer setting leaves a condition on a stale side. */
typedef struct { int side, on, by_rate; } Side;

static int sign_of(double v) { return (v > 0) - (v < 0); }
static double location_tolerance(double t) { return 1e-12 * (fabs(t) > 1 ? fabs(t) : 1); }

static int fresh_rates(Instance *m) { return ensure(m, &m->need_rates, F_ZERO_RATES, m->rates); }

/* the side of condition k at the present point (fresh rates); `near`: how far from 0 it still counts as on
 * its boundary (after its own event: where the importer located it). Within the round-off of the states
 * in its value and both rates it rests on its boundary (two pendulums hanging at rest, touching), and
 * within that of its value it is on its boundary */
static Side side_of(const Instance *m, int k, double near) {
    double g = m->rates[k], gd = m->rates[MN_NG + k], gdd = m->rates[2 * MN_NG + k];
    double noise = m->rates[3 * MN_NG + k], tol = location_tolerance(m->t);
    Side s;
    if (fabs(g) <= noise && fabs(gd) <= m->rates[4 * MN_NG + k] && fabs(gdd) <= m->rates[5 * MN_NG + k])
        g = gd = gdd = 0;
    s.on = g == 0 || fabs(g) <= fabs(gd) * tol || fabs(g) <= near || fabs(g) <= noise;
    s.by_rate = fabs(gd) > fabs(gdd) * tol;
    s.side = !s.on ? sign_of(g) : (s.by_rate ? sign_of(gd) : sign_of(gdd));
    return s;
}

/* armed on `before`, now on side `after`: falling from + to <= 0, rising from - to >= 0; from the boundary
 * only a directional condition crosses, by leaving it into its direction */
static int crosses(int direction, double before, int after) {
    if (before > 0) return after <= 0 && direction <= 0;
    if (before < 0) return after >= 0 && direction >= 0;
    return after != 0 && direction != 0 && after == direction;
}

/* armed on `before`, it fires on reaching side `after`: a crossing onto a side, never one that comes to rest
 * on its boundary (side 0: pendulums left touching at rest by an impact) */
static int fires(int direction, double before, int after) { return after != 0 && crosses(direction, before, after); }

/* left by its own reset on its boundary, held into its direction by d2g/dt2 alone: it crosses again */
static int fires_again(int direction, Side s) { return s.on && !s.by_rate && direction != 0 && s.side == direction; }

static void accept(Instance *m) {
    int k;
    for (k = 0; k < MN_NZ; k++) m->z_accepted[k] = m->z[k];
}

/* the step the importer takes (s): what it cannot resolve of an event sequence */
static double importer_step(const Instance *m) {
    double h = m->t - m->t_step > m->h_step ? m->t - m->t_step : m->h_step;
    return h > location_tolerance(m->t) ? h : location_tolerance(m->t);
}

/* the events of condition k, at t: its last four distinct times */
static void remember_event(Instance *m, int k) {
    int n = m->n_event_times[k];
    if (n && m->event_times[k][n < 4 ? n - 1 : 3] == m->t) return;
    if (n == 4) { memmove(m->event_times[k], m->event_times[k] + 1, 3 * sizeof(double)); n = 3; }
    m->event_times[k][n] = m->t;
    m->n_event_times[k] = n + 1;
}

/* T-infinity of condition k's events when their last three gaps shrink by a consistent ratio r < 1, else -1 */
static double accumulation_time(const Instance *m, int k) {
    const double *t = m->event_times[k];
    double g1, g2, g3, r1, r2, r;
    if (m->n_event_times[k] < 4) return -1;
    g1 = t[1] - t[0]; g2 = t[2] - t[1]; g3 = t[3] - t[2];
    if (g1 <= 0 || g2 <= 0 || g3 <= 0) return -1;
    r1 = g2 / g1; r2 = g3 / g2; r = r1 > r2 ? r1 : r2;
    if (!(r < 1 && fabs(r2 - r1) <= 0.1 * r)) return -1;
    return t[3] + g3 * r / (1 - r);
}

/* should condition k's events end in its rest: they repeat from the same state at this instant, or
 * accumulate (gaps shrinking geometrically) within the importer's step, or a rebound that loses speed is
 * shorter than that step; under fixed steps (an importer that does not locate events, `stepped_over`) also
 * one that loses less than the step's own error adds back over a flight of a few dozen steps (|d2g/dt2|·h
 * each: Euler gains that much, and the bounces never decay). A rebound that keeps its speed (e = 1) never
 * rests. */
static const char *rest_reason(const Instance *m, int k, Side s, int repeated, double gd_before) {
    double h = importer_step(m), t_inf = accumulation_time(m, k);
    double gd = m->rates[MN_NG + k], gdd = m->rates[2 * MN_NG + k], loss = fabs(gd_before) - fabs(gd);
    int rebound = s.by_rate && s.side == -mn_zero_direction[k] && sign_of(gdd) == -sign_of(gd)
        && loss > 1e-12 * fabs(gd_before);
    if (repeated) return "its reset leaves it crossing, so it fires again at the same instant";
    if (t_inf >= 0 && t_inf - m->t <= h) return "its events accumulate within the importer's step";
    if (!rebound) return 0;
    /* a root finder sees only a sign change between its steps: a bounce within one step is lost to it */
    if (2 * fabs(gd) <= fabs(gdd) * h) return "its rebound is shorter than the importer's step";
    if (m->stepped_over && loss <= MN_FIXED_STEP_GAIN * fabs(gdd) * h && 2 * fabs(gd) <= MN_FIXED_STEP_FLIGHT * fabs(gdd) * h)
        return "its rebound loses less speed than the importer's fixed step adds back over its flight";
    return 0;
}

/* condition k's events end in its rest transition (a plastic jump and the rest modes) */
static int come_to_rest(Instance *m, int k, const char *why) {
    double x_plus[MN_NX + 1], d_plus[MN_ND + 1];
    const double *in[6] = {&m->t, m->x, m->z, m->u, m->p, m->d};
    double *out[2] = {x_plus, d_plus};
    int st;
    if (mn_call(m, mn_rests[k].eval, m->mem[F_COUNT + MN_NT + k], in, 6, out, 2)) {
        logf_(m, ST_ERROR, "logStatusError", "t = %.17g: %s: its rest (a plastic jump) could not be evaluated",
              m->t, mn_zero_labels[k]);
        return ST_ERROR;
    }
    memcpy(m->x, x_plus, sizeof(double) * MN_NX);
    memcpy(m->d, d_plus, sizeof(double) * MN_ND);
    changed(m);
    if (m->logging) logf_(m, ST_OK, "logEvents", "t = %.17g: %s comes to rest: %s", m->t, mn_zero_labels[k], why);
    if ((st = fresh_rates(m)) != ST_OK) return st;
    m->armed[k] = side_of(m, k, 0).side;
    m->n_event_times[k] = 0;
    return ST_OK;
}

/* every condition on its present side, where it has one (one resting on its boundary keeps the side it
 * was on: coming to rest is no crossing) */
static int arm(Instance *m) {
    int k, st;
    if (MN_NG == 0) return ST_OK;
    if ((st = fresh_rates(m)) != ST_OK) return st;
    for (k = 0; k < MN_NG; k++) {
        Side s = side_of(m, k, 0);
        if (s.side != 0 && !crosses(mn_zero_direction[k], m->armed[k], s.side)) m->armed[k] = s.side;
    }
    return ST_OK;
}

/* condition k's transition (the jump at its event) applied to the present state */
static int transition(Instance *m, int k) {
    double x_plus[MN_NX + 1], d_plus[MN_ND + 1];
    const double *in[6] = {&m->t, m->x, m->z, m->u, m->p, m->d};
    double *out[2] = {x_plus, d_plus};
    int st = ensure_z(m);
    if (st != ST_OK) return st;
    if (mn_call(m, mn_transitions[k].eval, m->mem[F_COUNT + k], in, 6, out, 2)) {
        logf_(m, ST_ERROR, "logStatusError", "t = %.17g: %s: its transition (the jump at the event) could not be "
              "evaluated", m->t, mn_zero_labels[k]);
        return ST_ERROR;
    }
    memcpy(m->x, x_plus, sizeof(double) * MN_NX);
    memcpy(m->d, d_plus, sizeof(double) * MN_ND);
    changed(m);
    return ST_OK;
}

/* An importer that steps over a crossing (fixed steps: it sees it at a step's end, up to |dg/dt|·h past its
 * boundary) gets the event where the condition crossed: g/(dg/dt) before the step's end (linear
 * interpolation, at most the step; mechnet/core/events.py `crossed_ago`), for the first condition found
 * crossed off its boundary. Every state is carried back there along its derivatives, and the whole event
 * iteration runs at that instant: the transitions of that condition and of any other crossing with it (two
 * balls landing together keep landing together) and the rest rules, which compare speeds before and after
 * at the same point. When a round fires nothing the result is carried on to the step's end along the
 * derivatives after it (`carry_on`; one Euler step each way: the importer's own order). At the step's end
 * instead, friction sliding through v = 0 at 1.5 m/s^2 read 1.5e-3 m/s under a 1 ms Euler step, far above
 * v_small: "thrown" across, it slid back and forth, 123 switches in 10 s where the closed form has 11. Not for
 * scenes with loops (their equations are solved at the importer's states only). */
static int carry_back(Instance *m, int k) {
    double g = m->rates[k], gd = m->rates[MN_NG + k], ago = 0;
    int i, st;
    if (MN_NZ > 0 || side_of(m, k, m->near[k]).on) return ST_OK;
    if (gd != 0 && sign_of(g) == sign_of(gd)) ago = fmin(g / gd, m->h_step);
    if (!(ago > 0)) return ST_OK;
    if ((st = ensure(m, &m->need_xdot, F_ODE, m->xdot)) != ST_OK) return st;
    for (i = 0; i < MN_NX; i++) m->x[i] -= m->xdot[i] * ago;
    m->t -= ago;
    m->carried_back = ago;
    changed(m);
    if (m->logging) logf_(m, ST_OK, "logEvents", "t = %.17g: %s crossed %.3g s before the importer's step "
                          "ended: its event is taken there", m->t, mn_zero_labels[k], ago);
    return fresh_rates(m);
}

/* the states after an event taken where it crossed (`carry_back`) carried on to the importer's time */
static int carry_on(Instance *m) {
    double ago = m->carried_back;
    int i, st;
    if (!(ago > 0)) return ST_OK;
    if ((st = ensure(m, &m->need_xdot, F_ODE, m->xdot)) != ST_OK) return st;
    for (i = 0; i < MN_NX; i++) m->x[i] += m->xdot[i] * ago;
    m->t += ago;
    m->carried_back = 0;
    changed(m);
    accept(m);
    return ST_OK;
}

/* the discrete-state update (one round of FMI's event iteration): the first condition (in index order) that
 * crossed in its direction since it was armed fires, and takes the side its reset leaves it on; one left
 * crossing fires again (twice from the same instant: an accumulation its rest ends). Others crossing too
 * keep their side and are judged again after the reset; the rest take the side they are on before it, so
 * the next round sees a condition the reset threw across (a cascade: a cradle's impacts passing along the
 * row, each contact judged after the impact before it, so one thrown back into its neighbour strikes
 * again). A round that fires nothing arms every condition on its side. */
static int update_discrete(Instance *m, int *values_changed, int *needs_more) {
    int k, st, fired = 0, last = 0;
    signed char fired_here[MN_NG + 1];
    unsigned char earlier[MN_NG + 1];
    double before[MN_NG + 1], gd_before[MN_NG + 1];
    *values_changed = 0;
    *needs_more = 0;
    if (MN_NG == 0) return ST_OK;
    if ((st = fresh_rates(m)) != ST_OK) return st;
    if (m->stepped_over && m->event_rounds == 0 && !(m->carried_back > 0)) {
        for (k = 0; k < MN_NG; k++)             /* the first to fire: the event is taken where it crossed */
            if (fires(mn_zero_direction[k], m->armed[k], side_of(m, k, m->near[k]).side)) {
                if ((st = carry_back(m, k)) != ST_OK) return st;
                break;
            }
    }
    memset(fired_here, 0, sizeof fired_here);
    for (k = 0; k < MN_NG; k++) {
        Side s = side_of(m, k, m->near[k]);
        before[k] = m->armed[k];
        gd_before[k] = m->rates[MN_NG + k];
        earlier[k] = m->fired_now[k];
        /* one the importer located (found in the first round, reaching its boundary at speed) counts as on
         * its boundary within what it was located to; one a reset threw across does not (a cascade) */
        if (m->event_rounds == 0 && s.by_rate && s.side == mn_zero_direction[k])   /* kept over the rounds */
            m->near[k] = fmax(m->near[k], 2 * fmax(fabs(m->rates[k]), fabs(m->rates[MN_NG + k])
                                                   * location_tolerance(m->t)));
        if (!fires(mn_zero_direction[k], m->armed[k], s.side)) {
            if (s.side != 0) m->armed[k] = s.side;     /* moved the other way, or stayed */
            continue;
        }
        if (fired) continue;        /* crossing too: judged again after this round's reset */
        if ((st = transition(m, k)) != ST_OK) return st;
        fired_here[k] = 1;
        m->fired_now[k] = 1;
        remember_event(m, k);
        fired++;
        last = k;
        if (m->logging) logf_(m, ST_OK, "logEvents", "t = %.17g: %s", m->t, mn_zero_labels[k]);
    }
    if (!fired) {
        m->stepped_over = 0;
        if ((st = carry_on(m)) != ST_OK) return st;
        return arm(m);
    }
    if (++m->event_rounds > MN_MAX_EVENT_ROUNDS) {
        logf_(m, ST_ERROR, "logStatusError", "t = %.17g: events keep firing after %d rounds of discrete-state "
              "updates at the same time (the last: %s); the conditions chatter", m->t, MN_MAX_EVENT_ROUNDS,
              mn_zero_labels[last]);
        return ST_ERROR;
    }
    changed(m);
    *values_changed = 1;
    *needs_more = 1;                        /* another round: a reset may make another condition cross */
    if ((st = fresh_rates(m)) != ST_OK) return st;
    accept(m);
    for (k = 0; k < MN_NG; k++) {
        Side s;
        const char *why;
        if (!fired_here[k]) continue;
        s = side_of(m, k, m->near[k]);
        why = mn_rests[k].eval ? rest_reason(m, k, s, earlier[k] && fires_again(mn_zero_direction[k], s),
                                             gd_before[k]) : 0;
        if (why) {
            if ((st = come_to_rest(m, k, why)) != ST_OK) return st;
        } else if (fires_again(mn_zero_direction[k], s)) {
            m->armed[k] = before[k];            /* it crosses again in the next round */
        } else if (s.side != 0) {
            m->armed[k] = s.side;
        }
    }
    return ST_OK;
}

static int next_time_event(Instance *m, double *t_next) {
    int k;
    for (k = 0; k < MN_NTE; k++) {
        if (mn_time_events[k] > m->t * (1 + 1e-14) + 1e-14) { *t_next = mn_time_events[k]; return 1; }
    }
    return 0;
}

static Instance *create(const char *name, int logging) {
    Instance *m = (Instance *)calloc(1, sizeof(Instance));
    casadi_int sz_arg = 0, sz_res = 0, sz_iw = 0, sz_w = 0;
    int f;
    if (!m) return NULL;
    m->name = (char *)malloc(strlen(name) + 1);
    strcpy(m->name, name);
    m->logging = logging;
    for (f = 0; f < N_CALLED; f++) {
        const mn_function *fn = called(f);
        casadi_int a, r, i, w;
        if (!fn) continue;
        fn->work(&a, &r, &i, &w);
        sz_arg = a > sz_arg ? a : sz_arg;
        sz_res = r > sz_res ? r : sz_res;
        sz_iw = i > sz_iw ? i : sz_iw;
        sz_w = w > sz_w ? w : sz_w;
        m->mem[f] = fn->checkout();
    }
    m->arg = (const casadi_real **)calloc(sz_arg + 1, sizeof(casadi_real *));
    m->res = (casadi_real **)calloc(sz_res + 1, sizeof(casadi_real *));
    m->iw = (casadi_int *)calloc(sz_iw + 1, sizeof(casadi_int));
    m->w = (casadi_real *)calloc(sz_w + 1, sizeof(casadi_real));
    memcpy(m->u, mn_u_default, sizeof(double) * MN_NU);
    memcpy(m->p, mn_p_default, sizeof(double) * MN_NP);
    memcpy(m->d, mn_d_default, sizeof(double) * MN_ND);
    memcpy(m->s, mn_s_default, sizeof(double) * MN_NS);
    for (f = 0; f < MN_NG; f++) m->armed[f] = 1.0;
    m->need_init = 1;
    changed(m);
    m->mode = MODE_INSTANTIATED;
    return m;
}

static void destroy(Instance *m) {
    int f;
    if (!m) return;
    for (f = 0; f < N_CALLED; f++)
        if (called(f)) called(f)->release(m->mem[f]);
    free(m->arg); free(m->res); free(m->iw); free(m->w); free(m->name); free(m);
}

static int get_real(Instance *m, const uint32_t *vr, size_t n, double *value) {
    size_t i;
    int st;
    for (i = 0; i < n; i++) {
        uint32_t r = vr[i];
        if (r == 0) { value[i] = m->t; continue; }
        if (r > MN_NVAR) { logf_(m, ST_ERROR, "logStatusError", "no variable has value reference %u", r); return ST_ERROR; }
        switch (mn_vr_kind[r]) {
        case 0: if ((st = ensure(m, &m->need_y, F_OBSERVED, m->y)) != ST_OK) return st;
                value[i] = m->y[mn_vr_index[r]]; break;
        case 1: if ((st = ensure(m, &m->need_xdot, F_ODE, m->xdot)) != ST_OK) return st;
                value[i] = m->xdot[mn_vr_index[r]]; break;
        default: if ((st = ensure(m, &m->need_g, F_ZERO, m->g)) != ST_OK) return st;
                value[i] = m->g[mn_vr_index[r]]; break;
        }
    }
    return ST_OK;
}

static int check_parameters(Instance *m);

/* a call refused in event mode leaves every value as it was before it: parameters, inputs and states */
static void refuse_whole(Instance *m, const double *p, const double *u, const double *x) {
    memcpy(m->p, p, sizeof(double) * MN_NP);
    memcpy(m->u, u, sizeof(double) * MN_NU);
    memcpy(m->x, x, sizeof(double) * MN_NX);
    changed(m);
}

/* a NaN or infinite value given for a variable (vr) or a state (vr NULL) is refused whole: nothing of the call
 * is taken, so the instance keeps the values it had (a NaN input would otherwise reach the Newton iterations) */
static int finite_values(Instance *m, const char *what, const uint32_t *vr, const double *value, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (isfinite(value[i])) continue;
        if (vr && vr[i] <= MN_NVAR)
            logf_(m, ST_ERROR, "logStatusError", "%s: %s (value reference %u) = %g is not finite; nothing was set",
                  what, mn_vr_name[vr[i]], vr[i], value[i]);
        else if (vr)
            logf_(m, ST_ERROR, "logStatusError", "%s: value reference %u = %g is not finite; nothing was set",
                  what, vr[i], value[i]);
        else
            logf_(m, ST_ERROR, "logStatusError", "%s: state %s (value %lu) = %g is not finite; nothing was set",
                  what, mn_x_name[i], (unsigned long)i, value[i]);
        return ST_ERROR;
    }
    return ST_OK;
}

static int set_real(Instance *m, const uint32_t *vr, size_t n, const double *value) {
    size_t i;
    double p_before[MN_NP + 1], u_before[MN_NU + 1], x_before[MN_NX + 1];
    if (finite_values(m, "set a real value", vr, value, n) != ST_OK) return ST_ERROR;
    memcpy(p_before, m->p, sizeof(double) * MN_NP);
    memcpy(u_before, m->u, sizeof(double) * MN_NU);
    memcpy(x_before, m->x, sizeof(double) * MN_NX);
    for (i = 0; i < n; i++) {
        uint32_t r = vr[i];
        int where = r <= MN_NVAR ? mn_vr_set[r] : -1, k = r <= MN_NVAR ? mn_vr_set_index[r] : 0;
        int before_init = m->mode == MODE_INSTANTIATED || m->mode == MODE_INIT;
        if (where == 1 && before_init) { m->s[k] = value[i]; m->need_init = 1; }
        else if (where == 2) { m->u[k] = value[i]; if (before_init) m->need_init = 1; }
        else if (where == 3 && (before_init || m->mode == MODE_EVENT)) { m->p[k] = value[i]; if (before_init) m->need_init = 1; }
        else if (where == 4 && before_init) { m->d[k] = value[i]; m->need_init = 1; }
        else if (!before_init && r <= MN_NVAR && mn_vr_known[r] == 1) {
            m->x[mn_vr_known_index[r]] = value[i];      /* a state: as fmi2SetContinuousStates (CasADi's import) */
        }
        else {
            logf_(m, ST_ERROR, "logStatusError", "variable %s (value reference %u) cannot be set %s",
                  r <= MN_NVAR ? mn_vr_name[r] : "(none)", r, before_init ? "(it is calculated)" : "after initialisation (only inputs, and tunable parameters in "
                  "event mode)");
            if (m->mode == MODE_EVENT) refuse_whole(m, p_before, u_before, x_before);
            else if (i) changed(m);             /* the values before it were taken */
            return ST_ERROR;
        }
    }
    if (m->mode == MODE_EVENT && memcmp(p_before, m->p, sizeof(double) * MN_NP) && check_parameters(m) != ST_OK) {
        refuse_whole(m, p_before, u_before, x_before);
        return ST_ERROR;
    }
    if (n) changed(m);
    return ST_OK;
}

/* directional derivatives of derivatives and observed values along seeds of states, inputs, parameters */
static int directional(Instance *m, const uint32_t *unknown, size_t nu, const uint32_t *known, size_t nk,
                       const double *seed, double *sens) {
    double dx[MN_NX + 1] = {0}, du[MN_NU + 1] = {0}, dp[MN_NP + 1] = {0};
    double dxdot[MN_NX + 1], dy[MN_NY + 1], dz[MN_NZ + 1];
    const double *in[9] = {&m->t, m->x, m->z, m->u, m->p, m->d, dx, du, dp};
    double *out[3] = {dxdot, dy, dz};
    size_t i;
    int st;
    if ((st = ensure_init(m)) != ST_OK || (st = ensure_z(m)) != ST_OK) return st;
    for (i = 0; i < nk; i++) {
        uint32_t r = known[i];
        int k = r <= MN_NVAR ? mn_vr_known_index[r] : -1;
        switch (r <= MN_NVAR ? mn_vr_known[r] : -1) {
        case 1: dx[k] += seed[i]; break;
        case 2: du[k] += seed[i]; break;
        case 3: dp[k] += seed[i]; break;
        default:
            logf_(m, ST_ERROR, "logStatusError", "directional derivative: value reference %u is not a state, input "
                  "or parameter", r);
            return ST_ERROR;
        }
    }
    call(m, F_FORWARD, in, 9, out, 3);
    for (i = 0; i < nu; i++) {
        uint32_t r = unknown[i];
        if (r >= 1 && r <= MN_NVAR && mn_vr_kind[r] == 0) sens[i] = dy[mn_vr_index[r]];
        else if (r >= 1 && r <= MN_NVAR && mn_vr_kind[r] == 1) sens[i] = dxdot[mn_vr_index[r]];
        else {
            logf_(m, ST_ERROR, "logStatusError", "directional derivative: value reference %u is not a derivative or "
                  "an observed variable", r);
            return ST_ERROR;
        }
    }
    return ST_OK;
}

/* ---------------------------------------------------------------- what both FMI versions do alike */
static int enter_event_mode(Instance *m) {
    m->mode = MODE_EVENT;
    m->event_rounds = 0;
    memset(m->fired_now, 0, sizeof m->fired_now);
    memset(m->near, 0, sizeof m->near);
    return ST_OK;
}

/* the requirements between parameters (mu_s >= mu_k, stop limits: mechnet's core/requirements.py, the
 * tables of model_data.h): ST_ERROR naming the first one the parameter values break */
static int check_parameters(Instance *m) {
    int k;
    for (k = 0; k < MN_NP; k++) {
        double v = m->p[k];
        if (!isfinite(v)) {
            logf_(m, ST_ERROR, "logStatusError", "parameter %s = %g is not finite", mn_p_names[k], v);
            return ST_ERROR;
        }
        if ((mn_p_lower_strict[k] ? v > mn_p_lower[k] : v >= mn_p_lower[k]) && v <= mn_p_upper[k]) continue;
        logf_(m, ST_ERROR, "logStatusError", "parameter %s = %g %s", mn_p_names[k], v, mn_p_rule[k]);
        return ST_ERROR;
    }
    for (k = 0; k < MN_NR; k++) {
        double a = mn_req_lhs[k] >= 0 ? m->p[mn_req_lhs[k]] : mn_req_lhs_value[k];
        double b = mn_req_rhs[k] >= 0 ? m->p[mn_req_rhs[k]] : mn_req_rhs_value[k];
        if (mn_req_strict[k] ? a > b : a >= b) continue;
        logf_(m, ST_ERROR, "logStatusError", "%s: the values %g and %g break it", mn_req_text[k], a, b);
        return ST_ERROR;
    }
    return ST_OK;
}

static int exit_init(Instance *m) {
    int k, st = check_parameters(m);        /* values set one by one before: judged together here */
    if (st != ST_OK) return st;
    if ((st = ensure_init(m)) != ST_OK) return st;
    m->t_step = m->t;
    m->h_step = 0;
    m->stepped_over = 0;
    m->carried_back = 0;
    memset(m->n_event_times, 0, sizeof m->n_event_times);
    if (MN_NG && (st = fresh_rates(m)) != ST_OK) return st;
    /* every condition on its side; one on its boundary leaving it into its direction crosses now (a ball
     * placed on the floor falls onto it), and one marked at_start already past zero in its direction (a
     * friction element pushed beyond its static limit from the start): both fire in the first update */
    for (k = 0; k < MN_NG; k++) {
        Side s = side_of(m, k, 0);
        int dir = mn_zero_direction[k];
        m->armed[k] = s.side;
        if (dir && s.side == dir && (s.on || mn_zero_at_start[k])) m->armed[k] = -dir;
    }
    return enter_event_mode(m);
}

static int reset(Instance *m) {
    memcpy(m->u, mn_u_default, sizeof(double) * MN_NU);
    memcpy(m->p, mn_p_default, sizeof(double) * MN_NP);
    memcpy(m->d, mn_d_default, sizeof(double) * MN_ND);
    memcpy(m->s, mn_s_default, sizeof(double) * MN_NS);
    m->t = 0; m->need_init = 1; changed(m); m->mode = MODE_INSTANTIATED;
    return ST_OK;
}

/* an accepted integrator step: its length is what the importer resolves; a condition that crossed in
 * its direction during it asks for an event (an importer that missed the sign change of its indicator,
 * or stepped onto 0, still gets it), and the others take the side they are on */
static int completed_step(Instance *m, int *enter_event) {
    int k, st = ensure_z(m);
    *enter_event = 0;
    if (st != ST_OK) return st;
    accept(m);
    if (m->t > m->t_step) { m->h_step = m->t - m->t_step; m->t_step = m->t; }
    if (MN_NG == 0) return ST_OK;
    if ((st = fresh_rates(m)) != ST_OK) return st;
    for (k = 0; k < MN_NG; k++) {
        Side s = side_of(m, k, 0);
        if (fires(mn_zero_direction[k], m->armed[k], s.side)) {
            *enter_event = 1;
            /* reached at speed and well past its boundary (not where a root finder leaves it, within ~1e-9 s
             * at that speed): the importer stepped over it */
            if (s.by_rate && !s.on && fabs(m->rates[k]) > m->rates[3 * MN_NG + k]
                && fabs(m->rates[k]) > fabs(m->rates[MN_NG + k]) * 1e-9 * (fabs(m->t) > 1 ? fabs(m->t) : 1))
                m->stepped_over = 1;
        }
        else if (s.side != 0) m->armed[k] = s.side;
    }
    return ST_OK;
}

static int set_time(Instance *m, double t) {
    if (!isfinite(t)) {
        logf_(m, ST_ERROR, "logStatusError", "set time: t = %g is not finite; the time stays %.17g", t, m->t);
        return ST_ERROR;
    }
    m->t = t;
    changed(m);
    return ST_OK;
}

/* the start time an importer gives (fmi2SetupExperiment, fmi3EnterInitializationMode) */
static int start_time(Instance *m, double t) {
    if (isfinite(t)) { m->t = t; return ST_OK; }
    logf_(m, ST_ERROR, "logStatusError", "start time %g is not finite", t);
    return ST_ERROR;
}

/* a vector the importer passes: its length must be the model's */
static int sized(Instance *m, const char *what, size_t n, size_t expected) {
    if (n == expected) return ST_OK;
    logf_(m, ST_ERROR, "logStatusError", "%s: %lu values given, the model has %lu", what, (unsigned long)n,
          (unsigned long)expected);
    return ST_ERROR;
}

static int set_states(Instance *m, const double *x, size_t n) {
    if (sized(m, "set continuous states", n, MN_NX) != ST_OK) return ST_ERROR;
    if (finite_values(m, "set continuous states", NULL, x, n) != ST_OK) return ST_ERROR;
    memcpy(m->x, x, sizeof(double) * n);
    changed(m);
    return ST_OK;
}

static int get_vector(Instance *m, const char *what, int *need, int f, double *source, double *target, size_t n,
                      size_t expected) {
    int st = sized(m, what, n, expected);
    if (st == ST_OK && need) st = ensure(m, need, f, source);
    if (st == ST_OK && !need && source == m->x) st = ensure_init(m);
    if (st == ST_OK) memcpy(target, source, sizeof(double) * n);
    return st;
}
#define GET_DERIVATIVES(m, v, n) get_vector(m, "get derivatives", &(m)->need_xdot, F_ODE, (m)->xdot, v, n, MN_NX)
#define GET_INDICATORS(m, v, n) get_vector(m, "get event indicators", &(m)->need_g, F_ZERO, (m)->g, v, n, MN_NG)
#define GET_STATES(m, v, n) get_vector(m, "get continuous states", NULL, 0, (m)->x, v, n, MN_NX)
#define GET_NOMINALS(m, v, n) get_vector(m, "get nominals", NULL, 0, (double *)mn_x_nominal, v, n, MN_NX)

#if FMI_VERSION == 2
/* ---------------------------------------------------------------- FMI 2.0 Model Exchange */
typedef void *fmi2Component;
typedef int fmi2Boolean;
typedef unsigned int fmi2ValueReference;
typedef void (*fmi2CallbackLogger)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    fmi2CallbackLogger logger;
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(void *, int);
    void *componentEnvironment;
} fmi2CallbackFunctions;
typedef struct {
    fmi2Boolean newDiscreteStatesNeeded, terminateSimulation, nominalsOfContinuousStatesChanged,
        valuesOfContinuousStatesChanged, nextEventTimeDefined;
    double nextEventTime;
} fmi2EventInfo;

static void deliver(Instance *m, int status, const char *category, const char *text) {
    ((fmi2CallbackLogger)m->logger)(m->environment, m->name, status, category, "%s", text);
}

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }
EXPORT int fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const char *const cat[]) {
    (void)n; (void)cat; ((Instance *)c)->logging = on; return ST_OK; }

EXPORT fmi2Component fmi2Instantiate(const char *name, int type, const char *guid, const char *resources,
                                     const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean loggingOn) {
    Instance *m;
    (void)resources; (void)visible;
    if (type != 0 || strcmp(guid, MN_GUID) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, name, ST_ERROR, "logStatusError",
                              type != 0 ? "this FMU supports Model Exchange only" : "GUID %s does not match this FMU",
                              guid);
        return NULL;
    }
    m = create(name, loggingOn);
    if (m && functions) { m->logger = (void *)functions->logger; m->environment = functions->componentEnvironment; }
    return m;
}
EXPORT void fmi2FreeInstance(fmi2Component c) { destroy((Instance *)c); }
EXPORT int fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, double tol, double start, fmi2Boolean stopDefined, double stop) {
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stop; return start_time((Instance *)c, start); }
EXPORT int fmi2EnterInitializationMode(fmi2Component c) { ((Instance *)c)->mode = MODE_INIT; return ST_OK; }
EXPORT int fmi2ExitInitializationMode(fmi2Component c) { return exit_init((Instance *)c); }
EXPORT int fmi2Terminate(fmi2Component c) { ((Instance *)c)->mode = MODE_TERMINATED; return ST_OK; }
EXPORT int fmi2Reset(fmi2Component c) { return reset((Instance *)c); }
EXPORT int fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, double value[]) {
    return get_real((Instance *)c, (const uint32_t *)vr, n, value); }
EXPORT int fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const double value[]) {
    return set_real((Instance *)c, (const uint32_t *)vr, n, value); }
static int no_such(fmi2Component c, size_t n, const char *what) {
    if (n == 0) return ST_OK;
    logf_((Instance *)c, ST_ERROR, "logStatusError", "this FMU has no %s variables", what);
    return ST_ERROR;
}
EXPORT int fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, int v[]) { (void)vr; (void)v; return no_such(c, n, "Integer"); }
EXPORT int fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const int v[]) { (void)vr; (void)v; return no_such(c, n, "Integer"); }
EXPORT int fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { (void)vr; (void)v; return no_such(c, n, "Boolean"); }
EXPORT int fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { (void)vr; (void)v; return no_such(c, n, "Boolean"); }
EXPORT int fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const char *v[]) { (void)vr; (void)v; return no_such(c, n, "String"); }
EXPORT int fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const char *const v[]) { (void)vr; (void)v; return no_such(c, n, "String"); }
static int no_state(fmi2Component c) {
    logf_((Instance *)c, ST_ERROR, "logStatusError", "this FMU cannot save or restore its state (canGetAndSetFMUstate=false)");
    return ST_ERROR;
}
EXPORT int fmi2GetFMUstate(fmi2Component c, void **s) { (void)s; return no_state(c); }
EXPORT int fmi2SetFMUstate(fmi2Component c, void *s) { (void)s; return no_state(c); }
EXPORT int fmi2FreeFMUstate(fmi2Component c, void **s) { (void)s; return no_state(c); }
EXPORT int fmi2SerializedFMUstateSize(fmi2Component c, void *s, size_t *n) { (void)s; (void)n; return no_state(c); }
EXPORT int fmi2SerializeFMUstate(fmi2Component c, void *s, char b[], size_t n) { (void)s; (void)b; (void)n; return no_state(c); }
EXPORT int fmi2DeSerializeFMUstate(fmi2Component c, const char b[], size_t n, void **s) { (void)s; (void)b; (void)n; return no_state(c); }
EXPORT int fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[], size_t nu,
                                        const fmi2ValueReference known[], size_t nk, const double dv_known[], double dv_unknown[]) {
    return directional((Instance *)c, (const uint32_t *)unknown, nu, (const uint32_t *)known, nk, dv_known, dv_unknown); }
EXPORT int fmi2EnterEventMode(fmi2Component c) { return enter_event_mode((Instance *)c); }
EXPORT int fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Instance *m = (Instance *)c;
    int values_changed, more, st = update_discrete(m, &values_changed, &more);
    info->newDiscreteStatesNeeded = more;
    info->terminateSimulation = 0;
    info->nominalsOfContinuousStatesChanged = 0;
    info->valuesOfContinuousStatesChanged = values_changed;
    info->nextEventTimeDefined = next_time_event(m, &info->nextEventTime);
    return st;
}
EXPORT int fmi2EnterContinuousTimeMode(fmi2Component c) { ((Instance *)c)->mode = MODE_CONTINUOUS; return ST_OK; }
EXPORT int fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetPrior, fmi2Boolean *enterEventMode, fmi2Boolean *terminate) {
    int enter, st;
    (void)noSetPrior;
    *terminate = 0;
    st = completed_step((Instance *)c, &enter);
    *enterEventMode = enter ? 1 : 0;
    return st;
}
EXPORT int fmi2SetTime(fmi2Component c, double t) { return set_time((Instance *)c, t); }
EXPORT int fmi2SetContinuousStates(fmi2Component c, const double x[], size_t n) { return set_states((Instance *)c, x, n); }
EXPORT int fmi2GetDerivatives(fmi2Component c, double xdot[], size_t n) { return GET_DERIVATIVES((Instance *)c, xdot, n); }
EXPORT int fmi2GetEventIndicators(fmi2Component c, double g[], size_t n) { return GET_INDICATORS((Instance *)c, g, n); }
EXPORT int fmi2GetContinuousStates(fmi2Component c, double x[], size_t n) { return GET_STATES((Instance *)c, x, n); }
EXPORT int fmi2GetNominalsOfContinuousStates(fmi2Component c, double nominal[], size_t n) {
    return GET_NOMINALS((Instance *)c, nominal, n); }

#else
/* ---------------------------------------------------------------- FMI 3.0 Model Exchange */
typedef void *fmi3Instance;
typedef uint32_t fmi3ValueReference;
typedef void (*fmi3LogMessageCallback)(void *, int, const char *, const char *);
#define UNSUPPORTED(m, what) (logf_((Instance *)(m), ST_ERROR, "logStatusError", "%s is not supported by this Model Exchange FMU", what), ST_ERROR)

static void deliver(Instance *m, int status, const char *category, const char *text) {
    ((fmi3LogMessageCallback)m->logger)(m->environment, status, category, text);
}

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }
EXPORT int fmi3SetDebugLogging(fmi3Instance c, bool on, size_t n, const char *const cat[]) {
    (void)n; (void)cat; ((Instance *)c)->logging = on; return ST_OK; }
EXPORT fmi3Instance fmi3InstantiateModelExchange(const char *name, const char *token, const char *resources, bool visible,
                                                 bool loggingOn, void *environment, fmi3LogMessageCallback log) {
    Instance *m;
    (void)resources; (void)visible;
    if (strcmp(token, MN_GUID) != 0) {
        if (log) log(environment, ST_ERROR, "logStatusError", "instantiation token does not match this FMU");
        return NULL;
    }
    m = create(name, loggingOn);
    if (m) { m->logger = (void *)log; m->environment = environment; }
    return m;
}
EXPORT fmi3Instance fmi3InstantiateCoSimulation(const char *a, const char *b, const char *c, bool d, bool e, bool f, bool g,
                                                const fmi3ValueReference h[], size_t i, void *j, void *k, void *l) {
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g; (void)h; (void)i; (void)j; (void)k; (void)l; return NULL; }
EXPORT fmi3Instance fmi3InstantiateScheduledExecution(const char *a, const char *b, const char *c, bool d, bool e, void *f,
                                                      void *g, void *h, void *i, void *j) {
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g; (void)h; (void)i; (void)j; return NULL; }
EXPORT void fmi3FreeInstance(fmi3Instance c) { destroy((Instance *)c); }
EXPORT int fmi3EnterInitializationMode(fmi3Instance c, bool tolDefined, double tol, double start, bool stopDefined, double stop) {
    Instance *m = (Instance *)c;
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stop;
    if (start_time(m, start) != ST_OK) return ST_ERROR;
    m->mode = MODE_INIT; m->need_init = 1; return ST_OK; }
EXPORT int fmi3ExitInitializationMode(fmi3Instance c) { return exit_init((Instance *)c); }
EXPORT int fmi3EnterEventMode(fmi3Instance c) { return enter_event_mode((Instance *)c); }
EXPORT int fmi3Terminate(fmi3Instance c) { ((Instance *)c)->mode = MODE_TERMINATED; return ST_OK; }
EXPORT int fmi3Reset(fmi3Instance c) { return reset((Instance *)c); }
/* every variable of this FMU is a scalar: n value references take exactly n values, and a caller's buffer
 * of another length is refused before anything is read or written (never a write past its end) */
static int scalars(Instance *m, const char *call, const char *what, size_t n_refs, size_t n_values) {
    if (n_values == n_refs) return ST_OK;
    logf_(m, ST_ERROR, "logStatusError", "%s: %s = %lu for %lu value references; every variable of this FMU is a "
          "scalar, so they must be equal", call, what, (unsigned long)n_values, (unsigned long)n_refs);
    return ST_ERROR;
}
EXPORT int fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, double v[], size_t nv) {
    Instance *m = (Instance *)c;
    return scalars(m, "fmi3GetFloat64", "nValues", n, nv) != ST_OK ? ST_ERROR : get_real(m, vr, n, v); }
EXPORT int fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const double v[], size_t nv) {
    Instance *m = (Instance *)c;
    return scalars(m, "fmi3SetFloat64", "nValues", n, nv) != ST_OK ? ST_ERROR : set_real(m, vr, n, v); }
#define NO_TYPE(T, C) \
    EXPORT int fmi3Get##T(fmi3Instance c, const fmi3ValueReference vr[], size_t n, C v[], size_t nv) { \
        (void)vr; (void)v; (void)nv; return n ? UNSUPPORTED(c, "a " #T " variable") : ST_OK; } \
    EXPORT int fmi3Set##T(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const C v[], size_t nv) { \
        (void)vr; (void)v; (void)nv; return n ? UNSUPPORTED(c, "a " #T " variable") : ST_OK; }
NO_TYPE(Float32, float)
NO_TYPE(Int8, int8_t)
NO_TYPE(UInt8, uint8_t)
NO_TYPE(Int16, int16_t)
NO_TYPE(UInt16, uint16_t)
NO_TYPE(Int32, int32_t)
NO_TYPE(UInt32, uint32_t)
NO_TYPE(Int64, int64_t)
NO_TYPE(UInt64, uint64_t)
NO_TYPE(Boolean, bool)
NO_TYPE(String, char *)
EXPORT int fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, size_t s[], uint8_t *v[], size_t nv) {
    (void)vr; (void)s; (void)v; (void)nv; return n ? UNSUPPORTED(c, "a Binary variable") : ST_OK; }
EXPORT int fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t s[], const uint8_t *const v[], size_t nv) {
    (void)vr; (void)s; (void)v; (void)nv; return n ? UNSUPPORTED(c, "a Binary variable") : ST_OK; }
EXPORT int fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, bool v[]) {
    (void)vr; (void)v; return n ? UNSUPPORTED(c, "a Clock") : ST_OK; }
EXPORT int fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const bool v[]) {
    (void)vr; (void)v; return n ? UNSUPPORTED(c, "a Clock") : ST_OK; }
EXPORT int fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference vr, size_t *n) {
    (void)vr; (void)n; return UNSUPPORTED(c, "fmi3GetNumberOfVariableDependencies (see ModelStructure)"); }
EXPORT int fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference a, size_t b[], fmi3ValueReference d[], size_t e[], int f[], size_t g) {
    (void)a; (void)b; (void)d; (void)e; (void)f; (void)g; return UNSUPPORTED(c, "fmi3GetVariableDependencies (see ModelStructure)"); }
EXPORT int fmi3GetFMUState(fmi3Instance c, void **s) { (void)s; return UNSUPPORTED(c, "saving the FMU state"); }
EXPORT int fmi3SetFMUState(fmi3Instance c, void *s) { (void)s; return UNSUPPORTED(c, "restoring the FMU state"); }
EXPORT int fmi3FreeFMUState(fmi3Instance c, void **s) { (void)s; return UNSUPPORTED(c, "freeing an FMU state"); }
EXPORT int fmi3SerializedFMUStateSize(fmi3Instance c, void *s, size_t *n) { (void)s; (void)n; return UNSUPPORTED(c, "serialising the FMU state"); }
EXPORT int fmi3SerializeFMUState(fmi3Instance c, void *s, uint8_t b[], size_t n) { (void)s; (void)b; (void)n; return UNSUPPORTED(c, "serialising the FMU state"); }
EXPORT int fmi3DeserializeFMUState(fmi3Instance c, const uint8_t b[], size_t n, void **s) { (void)s; (void)b; (void)n; return UNSUPPORTED(c, "deserialising the FMU state"); }
EXPORT int fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknown[], size_t nu,
                                        const fmi3ValueReference known[], size_t nk, const double seed[], size_t ns,
                                        double sens[], size_t nsens) {
    Instance *m = (Instance *)c;
    if (scalars(m, "fmi3GetDirectionalDerivative", "nSeed", nk, ns) != ST_OK
        || scalars(m, "fmi3GetDirectionalDerivative", "nSensitivity", nu, nsens) != ST_OK) return ST_ERROR;
    return directional(m, unknown, nu, known, nk, seed, sens); }
EXPORT int fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference a[], size_t b, const fmi3ValueReference d[], size_t e,
                                    const double f[], size_t g, double h[], size_t i) {
    (void)a; (void)b; (void)d; (void)e; (void)f; (void)g; (void)h; (void)i; return UNSUPPORTED(c, "adjoint derivatives"); }
EXPORT int fmi3EnterConfigurationMode(fmi3Instance c) { return UNSUPPORTED(c, "configuration mode"); }
EXPORT int fmi3ExitConfigurationMode(fmi3Instance c) { return UNSUPPORTED(c, "configuration mode"); }
EXPORT int fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference a[], size_t b, double d[], int e[]) {
    (void)a; (void)b; (void)d; (void)e; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference a[], size_t b, uint64_t d[], uint64_t e[], int f[]) {
    (void)a; (void)b; (void)d; (void)e; (void)f; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference a[], size_t b, double d[]) {
    (void)a; (void)b; (void)d; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference a[], size_t b, uint64_t d[], uint64_t e[]) {
    (void)a; (void)b; (void)d; (void)e; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference a[], size_t b, const double d[]) {
    (void)a; (void)b; (void)d; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference a[], size_t b, const uint64_t d[], const uint64_t e[]) {
    (void)a; (void)b; (void)d; (void)e; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference a[], size_t b, const double d[]) {
    (void)a; (void)b; (void)d; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference a[], size_t b, const uint64_t d[], const uint64_t e[]) {
    (void)a; (void)b; (void)d; (void)e; return UNSUPPORTED(c, "clocks"); }
EXPORT int fmi3EvaluateDiscreteStates(fmi3Instance c) { return UNSUPPORTED(c, "fmi3EvaluateDiscreteStates"); }
EXPORT int fmi3UpdateDiscreteStates(fmi3Instance c, bool *needUpdate, bool *terminate, bool *nominalsChanged,
                                    bool *valuesChanged, bool *nextDefined, double *nextTime) {
    Instance *m = (Instance *)c;
    int values_changed, more, st = update_discrete(m, &values_changed, &more);
    *needUpdate = more; *terminate = false; *nominalsChanged = false; *valuesChanged = values_changed;
    *nextDefined = next_time_event(m, nextTime);
    return st;
}
EXPORT int fmi3EnterContinuousTimeMode(fmi3Instance c) { ((Instance *)c)->mode = MODE_CONTINUOUS; return ST_OK; }
EXPORT int fmi3CompletedIntegratorStep(fmi3Instance c, bool noSetPrior, bool *enterEventMode, bool *terminate) {
    int enter, st;
    (void)noSetPrior;
    *terminate = false;
    st = completed_step((Instance *)c, &enter);
    *enterEventMode = enter != 0;
    return st;
}
EXPORT int fmi3SetTime(fmi3Instance c, double t) { return set_time((Instance *)c, t); }
EXPORT int fmi3SetContinuousStates(fmi3Instance c, const double x[], size_t n) { return set_states((Instance *)c, x, n); }
EXPORT int fmi3GetContinuousStateDerivatives(fmi3Instance c, double xdot[], size_t n) { return GET_DERIVATIVES((Instance *)c, xdot, n); }
EXPORT int fmi3GetEventIndicators(fmi3Instance c, double g[], size_t n) { return GET_INDICATORS((Instance *)c, g, n); }
EXPORT int fmi3GetContinuousStates(fmi3Instance c, double x[], size_t n) { return GET_STATES((Instance *)c, x, n); }
EXPORT int fmi3GetNominalsOfContinuousStates(fmi3Instance c, double nominal[], size_t n) {
    return GET_NOMINALS((Instance *)c, nominal, n); }
EXPORT int fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = MN_NG; return ST_OK; }
EXPORT int fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = MN_NX; return ST_OK; }
EXPORT int fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference a[], size_t b, const int d[], double e[], size_t f) {
    (void)a; (void)b; (void)d; (void)e; (void)f; return UNSUPPORTED(c, "output derivatives (Co-Simulation)"); }
EXPORT int fmi3EnterStepMode(fmi3Instance c) { return UNSUPPORTED(c, "Co-Simulation"); }
EXPORT int fmi3DoStep(fmi3Instance c, double a, double b, bool d, bool *e, bool *f, bool *g, double *h) {
    (void)a; (void)b; (void)d; (void)e; (void)f; (void)g; (void)h; return UNSUPPORTED(c, "Co-Simulation"); }
EXPORT int fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference a, double b) {
    (void)a; (void)b; return UNSUPPORTED(c, "Scheduled Execution"); }
#endif
