/* Cycloid drive, native FMU: interpolation of the loss map and the step's torques.
 * See cd_model.h. Every function mirrors one Python function, named in its comment, operation
 * for operation (tests/test_native_fmu.py compares them). cyclo-fmu, MIT license. */
#include <ctype.h>
#include <math.h>
#include <string.h>

#include "cd_model.h"

static const char *const MODE_NAMES[CD_N_MODES] = {"12", "21", "1S", "S1", "2S", "S2"};

int cd_mode_index(const char *mode)
{
    /* kinematics.parse_mode: strip, upper case, one of the six */
    char buf[3];
    size_t n, i0 = 0, i;
    int m;
    if (mode == NULL) return -1;
    n = strlen(mode);
    while (i0 < n && isspace((unsigned char)mode[i0])) i0++;
    while (n > i0 && isspace((unsigned char)mode[n - 1])) n--;
    if (n - i0 != 2) return -1;
    for (i = 0; i < 2; i++) buf[i] = (char)toupper((unsigned char)mode[i0 + i]);
    buf[2] = '\0';
    for (m = 0; m < CD_N_MODES; m++)
        if (strcmp(buf, MODE_NAMES[m]) == 0) return m;
    return -1;
}

/* bisect.bisect_right(a, x): the number of grid values <= x */
static int bisect_right(const double *a, int n, double x)
{
    int lo = 0, hi = n;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (x < a[mid]) hi = mid; else lo = mid + 1;
    }
    return lo;
}

/* ModeMap._interp: bilinear in (ln|tau|, ln|w|), clamped at the edges */
static int interp(const CDMap *map, const double *table, double t, double w, double *row)
{
    const double *gt = map->lt, *gw = map->lw;
    int nt = map->n_torque, nw = map->n_speed, clamped = 0, i, j, c;
    double lt = t > 0 ? log(t) : gt[0];
    double lw = w > 0 ? log(w) : gw[0];
    double ft, fw, u, v, x, y;
    const double *r00, *r01, *r10, *r11;
    if (lt < gt[0] || lt > gt[nt - 1] || lw < gw[0] || lw > gw[nw - 1]) {
        if (t > 0 && w > 0) clamped = 1;
        lt = fmin(fmax(lt, gt[0]), gt[nt - 1]);
        lw = fmin(fmax(lw, gw[0]), gw[nw - 1]);
    }
    i = bisect_right(gt, nt, lt) - 1;
    if (i < 0) i = 0;
    if (i > nt - 2) i = nt - 2;
    j = bisect_right(gw, nw, lw) - 1;
    if (j < 0) j = 0;
    if (j > nw - 2) j = nw - 2;
    ft = (lt - gt[i]) / (gt[i + 1] - gt[i]);
    fw = (lw - gw[j]) / (gw[j + 1] - gw[j]);
    r00 = table + ((size_t)j * nt + i) * CD_N_COLS;          /* row0[i] */
    r01 = r00 + CD_N_COLS;                                   /* row0[i + 1] */
    r10 = table + ((size_t)(j + 1) * nt + i) * CD_N_COLS;    /* row1[i] */
    r11 = r10 + CD_N_COLS;                                   /* row1[i + 1] */
    u = (1 - fw) * (1 - ft);
    v = (1 - fw) * ft;
    x = fw * (1 - ft);
    y = fw * ft;
    for (c = 0; c < CD_N_COLS; c++)
        row[c] = u * r00[c] + v * r01[c] + x * r10[c] + y * r11[c];
    return clamped;
}

/* ModeMap._interp_speed: linear in ln|w|, clamped at both ends; below the lowest speed
 * proportional to w (w_low = exp(lw[0]), stored as map->w_low). The bottom clamp matters: w a
 * little above w_low can have log(w) one ulp below lw[0] (exp and log round), and the index
 * would then be -1. */
static void interp_speed(const CDMap *map, const double *idle, double w, double *row)
{
    const double *gw = map->lw;
    int nw = map->n_speed, j, c;
    double lw, fw;
    const double *r0, *r1;
    if (w < map->w_low) {
        for (c = 0; c < CD_N_IDLE; c++) row[c] = idle[c] * (w / map->w_low);
        return;
    }
    lw = fmin(fmax(log(w), gw[0]), gw[nw - 1]);
    j = bisect_right(gw, nw, lw) - 1;
    if (j < 0) j = 0;
    if (j > nw - 2) j = nw - 2;
    fw = (lw - gw[j]) / (gw[j + 1] - gw[j]);
    r0 = idle + (size_t)j * CD_N_IDLE;
    r1 = r0 + CD_N_IDLE;
    for (c = 0; c < CD_N_IDLE; c++) row[c] = (1 - fw) * r0[c] + fw * r1[c];
}

void cd_solve(const CDMap *map, int mode, double w_in, double tau_out, CDSolution *out)
{
    const CDMode *m = &map->modes[mode];
    double row[CD_N_COLS], q[CD_N_IDLE], drag[3], gear[3];
    double eta0, e, c2, c[3], T1, tau, sgn, w_abs, p_gear, p_a, p_b, p_in, p_out;
    int k = m->b, forward, wdir, locked, i;
    out->speeds[0] = m->ratio[0] * w_in;
    out->speeds[1] = m->ratio[1] * w_in;
    out->speeds[2] = m->ratio[2] * w_in;
    w_abs = fabs(w_in);
    interp_speed(map, m->idle, w_abs, q);
    sgn = w_in > 0 ? 1.0 : (w_in < 0 ? -1.0 : 0.0);
    drag[0] = sgn * q[3];
    drag[1] = sgn * q[4];
    drag[2] = sgn * q[5];
    tau = tau_out - drag[k];                /* the gear's own torque at the driven shaft */
    forward = tau * out->speeds[k] <= 0;
    out->out_of_range = interp(map, m->table[forward], fabs(tau), w_abs, row);
    eta0 = row[0];
    wdir = m->wdir[forward];
    if (wdir > 0)
        e = eta0;
    else if (k == 2)   /* the known torque is on S: keep 1 - i0/eta0 off zero (locking pole) */
        e = 1.0 / (eta0 >= map->i0 * (1 + 1e-9) ? eta0 : map->i0 * (1 + 1e-9));
    else
        e = 1.0 / eta0;
    c2 = -map->i0 * e;
    c[0] = 1.0;
    c[1] = c2;
    c[2] = -(1.0 + c2);
    T1 = tau / c[k];
    gear[0] = T1;
    gear[1] = T1 * c2;
    gear[2] = T1 * c[2];
    p_gear = gear[0] * out->speeds[0] + gear[1] * out->speeds[1] + gear[2] * out->speeds[2];
    for (i = 0; i < CD_N_GEAR; i++) out->losses[i] = row[1 + i] * p_gear;
    for (i = 0; i < 3; i++) out->losses[CD_N_GEAR + i] = q[i] * w_abs;
    out->losses[CD_N_GEAR + 3] = row[1 + CD_N_GEAR] * p_gear;   /* PL_mesh */
    for (i = 0; i < 3; i++) out->torques[i] = gear[i] + drag[i];
    p_a = out->torques[m->a] * out->speeds[m->a];
    p_b = out->torques[k] * out->speeds[k];
    if (forward) { p_in = p_a; p_out = -p_b; }
    else         { p_in = p_b; p_out = -p_a; }
    /* Kreines: only power flowing into S from 1 or 2 can lock, when eta0 <= i0 */
    locked = (forward ? m->b == 2 : m->a == 2) && eta0 <= map->i0;
    out->eta = (p_in > 0 && p_out > 0 && !locked) ? p_out / p_in : 0.0;
    out->eta0 = eta0;
    out->locked = locked;
    out->forward = forward;
}

/* effects._drag and effects._stribeck as ExtraPhysics.steady_torque combines them */
#define CD_W_REF 300.0   /* rad/s, reference speed of the drag law (model_core.effects.W_REF) */

static double sign(double w) { return w > 0 ? 1.0 : (w < 0 ? -1.0 : 0.0); }

/* model_core.friction.reversal_sign: tanh(w/w_r), the sharp sign at w_r = 0 */
static double reversal_sign(double w, double w_r)
{
    return w_r > 0 ? tanh(w / w_r) : sign(w);
}

/* model_core.friction.loss_transition: tanh(|w|/w_c), 1 at w_c = 0 */
double cd_loss_transition(const CDExtra *x, double w)
{
    return x->loss_transition > 0 ? reversal_sign(fabs(w), x->loss_transition) : 1.0;
}

double cd_steady_torque(const CDExtra *x, double w)
{
    double t = x->drag_torque * (sign(w) * pow(fabs(w) / CD_W_REF, x->drag_exponent));
    if (x->stribeck_torque != 0) {
        double q = fabs(w) / x->stribeck_speed;
        t = t + x->stribeck_torque * (reversal_sign(w, x->stribeck_transition)
                                      * exp(-pow(q, x->stribeck_exponent)));
    }
    return t;
}

double cd_run_in_torque(const CDExtra *x, double distance, double load_loss_in)
{
    return x->run_in_change * exp(-distance / x->run_in_distance) * load_loss_in;
}

double cd_load_loss_torque(double P_load, double w_in)
{
    return w_in != 0.0 ? P_load / w_in : 0.0;
}

/* model_core.discovered: reference load of the terms (T_REF), N*m */
#define CD_T_REF 10.0

double cd_load_ripple_torque(const CDExtra *x, double theta, double order, double tau_out)
{
    return (fabs(tau_out) / CD_T_REF)
           * (x->ripple_1x_load * sin(theta + x->ripple_1x_load_phase)
              + x->ripple_roller_load * sin(order * theta + x->ripple_roller_load_phase));
}

/* one order k of ExtraPhysics.shaft_order_ripple_torque, in its order of operations */
static double order_ripple(double a, double phase, double b, double load_phase, double k,
                           double theta, double load, double total)
{
    double angle;
    if (a == 0.0 && b == 0.0) return total;
    angle = k * theta;
    if (a != 0.0) total = total + a * sin(angle + phase);
    if (b != 0.0) total = total + load * b * sin(angle + load_phase);
    return total;
}

double cd_shaft_order_ripple_torque(const CDExtra *x, double theta, double ratio_out,
                                    double tau_out)
{
    double load = fabs(tau_out) / CD_T_REF, total = 0.0;
    /* model_core.design.SHAFT_ORDER_RIPPLES: k = k_in + k_out r */
    total = order_ripple(x->ripple_2x, x->ripple_2x_phase, x->ripple_2x_load,
                         x->ripple_2x_load_phase, 2.0 + 0.0 * ratio_out, theta, load, total);
    total = order_ripple(x->ripple_out_1x, x->ripple_out_1x_phase, x->ripple_out_1x_load,
                         x->ripple_out_1x_load_phase, 0.0 + 1.0 * ratio_out, theta, load, total);
    total = order_ripple(x->ripple_out_2x, x->ripple_out_2x_phase, x->ripple_out_2x_load,
                         x->ripple_out_2x_load_phase, 0.0 + 2.0 * ratio_out, theta, load, total);
    return total;
}

double cd_discovered_torque(const CDTerm *terms, int n, double w, double tau_out)
{
    double total = 0.0;
    int k;
    for (k = 0; k < n; k++)
        total = total + terms[k].coefficient
                * (sign(w) * pow(fabs(w) / CD_W_REF, terms[k].speed_exponent)
                   * pow(fabs(tau_out) / CD_T_REF, terms[k].load_exponent));
    return total;
}

double cd_dynamic_torque(const CDExtra *x, double alpha, double theta, double order,
                         double elapsed, double loss_in)
{
    return x->input_inertia * alpha
           + x->ripple_1x * sin(theta + x->ripple_1x_phase)
           + x->ripple_roller * sin(order * theta + x->ripple_roller_phase)
           + x->thermal_loss_change * (1.0 - exp(-elapsed / x->thermal_tau)) * loss_in;
}

/* ExtraPhysics.thermal_per_10K_torque: c g(T - T_ref) loss_in, T the grease temperature, g
 * the warm-up's temperature law (model_core.thermal.loss_temperature_law): (T - T_ref)/10 K
 * with thermal_T_scale 0, else (theta/10 K)(1 - exp(-(T - T_ref)/theta)) */
double cd_thermal_per_10K_torque(const CDExtra *x, double T, double loss_in)
{
    double theta = x->thermal_T_scale;
    if (theta == 0.0)
        return x->thermal_loss_per_10K * (T - x->thermal_T_ref) / 10.0 * loss_in;
    return x->thermal_loss_per_10K * (theta / 10.0 * -expm1(-(T - x->thermal_T_ref) / theta))
           * loss_in;
}

/* ThermalMap.locate, ThermalMap.solve and lossmap.blend_solutions */
void cd_solve_thermal(const CDThermalMap *tm, int mode, double w_in, double tau_out, double T,
                      CDSolution *out)
{
    const double *nodes = tm->T;
    int n = tm->n, i, c, ia, ib;
    double x, f, g, p_a, p_b, p_in, p_out;
    CDSolution b;
    const CDSolution *near;
    if (n == 1) { cd_solve(&tm->maps[0], mode, w_in, tau_out, out); return; }
    x = fmin(fmax(T, nodes[0]), nodes[n - 1]);
    i = bisect_right(nodes, n, x) - 1;
    if (i > n - 2) i = n - 2;
    f = (x - nodes[i]) / (nodes[i + 1] - nodes[i]);
    cd_solve(&tm->maps[i], mode, w_in, tau_out, out);
    if (f == 0.0) return;
    cd_solve(&tm->maps[i + 1], mode, w_in, tau_out, &b);
    g = 1.0 - f;
    for (c = 0; c < 3; c++) out->torques[c] = g * out->torques[c] + f * b.torques[c];
    for (c = 0; c < CD_N_LOSSES; c++) out->losses[c] = g * out->losses[c] + f * b.losses[c];
    out->eta0 = g * out->eta0 + f * b.eta0;
    out->out_of_range = out->out_of_range || b.out_of_range;
    if (!(f < 0.5)) {
        near = &b;
        out->locked = near->locked;
        out->forward = near->forward;
    }
    ia = tm->maps[0].modes[mode].a;
    ib = tm->maps[0].modes[mode].b;
    p_a = out->torques[ia] * out->speeds[ia];
    p_b = out->torques[ib] * out->speeds[ib];
    if (out->forward) { p_in = p_a; p_out = -p_b; }
    else              { p_in = p_b; p_out = -p_a; }
    out->eta = (p_in > 0 && p_out > 0 && !out->locked) ? p_out / p_in : 0.0;
}

double cd_housing_step(double T, double P, double dt, double T_amb, double C, double R)
{
    double steady = T_amb + P * R;
    return steady + (T - steady) * exp(-dt / (R * C));
}
