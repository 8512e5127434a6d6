/* Native InductionMotor: the induction motor on a V/f frequency regulator (Kloss curve,
 * setpoint ramp, the train's inertia), the C twin of cyclo_fmu/slaves/motor.py and
 * model_core.rig.InductionMotor (same arithmetic, same order). */
#include <math.h>
#include <stdio.h>

#include "rig_model.h"

#define SUBSTEP 2.5e-4   /* s; motor._SUBSTEP: a twentieth of the rotor's time constant */
#define PI 3.141592653589793

static const int SCHED_T[8] = {R_schedule_time_1, R_schedule_time_2, R_schedule_time_3,
                               R_schedule_time_4, R_schedule_time_5, R_schedule_time_6,
                               R_schedule_time_7, R_schedule_time_8};
static const int SCHED_V[8] = {R_schedule_value_1, R_schedule_value_2, R_schedule_value_3,
                               R_schedule_value_4, R_schedule_value_5, R_schedule_value_6,
                               R_schedule_value_7, R_schedule_value_8};

/* x[]: the Kloss constants, prepared by rig_setup */
enum { X_C_SYNC, X_DWK, X_TK2 };

static double torque(const RigState *s, double w, double f)
{
    double dw = s->x[X_C_SYNC] * f - w;
    if (dw == 0.0) return 0.0;
    return s->x[X_TK2] / (dw / s->x[X_DWK] + s->x[X_DWK] / dw);
}

int rig_setup(RigState *s, char *msg, size_t n)
{
    static const int positive[] = {R_rated_power, R_rated_speed, R_rated_frequency, R_J,
                                   R_ramp_rate};
    static const char *const names[] = {"rated_power", "rated_speed", "rated_frequency", "J",
                                        "ramp_rate"};
    double times[8], values[8], k, rated_torque, slip, x;
    int j, p = s->i[I_pole_pairs];
    for (j = 0; j < 5; j++) {
        double v = s->r[positive[j]];
        if (!(isfinite(v) && v > 0)) {
            snprintf(msg, n, "%s = %g: must be positive", names[j], v);
            return 1;
        }
    }
    if (!(s->r[R_breakdown_ratio] > 1)) {
        snprintf(msg, n, "breakdown_ratio = %g: must exceed 1", s->r[R_breakdown_ratio]);
        return 1;
    }
    if (p < 1) {
        snprintf(msg, n, "pole_pairs = %d: must be at least 1", p);
        return 1;
    }
    for (j = 0; j < 8; j++) { times[j] = s->r[SCHED_T[j]]; values[j] = s->r[SCHED_V[j]]; }
    if (rig_load_schedule(s, "frequency_schedule", s->s[S_frequency_schedule],
                          s->i[I_schedule_points], times, values, msg, n))
        return 1;
    if (s->i[I_f_count] < 1 || s->i[I_loads_per_frequency] < 1) {
        snprintf(msg, n, "f_count and loads_per_frequency must be at least 1");
        return 1;
    }
    /* model_core.rig.InductionMotor.torque_function */
    k = s->r[R_breakdown_ratio];
    rated_torque = s->r[R_rated_power] / s->r[R_rated_speed];
    slip = 2 * PI * s->r[R_rated_frequency] / p - s->r[R_rated_speed];
    if (!(slip > 0)) {
        snprintf(msg, n, "rated_speed = %g: must lie below the synchronous speed %g rad/s",
                 s->r[R_rated_speed], 2 * PI * s->r[R_rated_frequency] / p);
        return 1;
    }
    x = k - sqrt(k * k - 1);
    s->x[X_C_SYNC] = 2 * PI / p;
    s->x[X_DWK] = slip / x;
    s->x[X_TK2] = 2 * k * rated_torque;
    return 0;
}

static double setpoint(const RigState *s, double t)
{
    if (s->n_schedule > 0) return rig_schedule_value(s, t);
    return rig_series_value(t, s->r[R_f_first], s->r[R_f_last], s->i[I_f_count],
                            s->r[R_hold_time], s->i[I_loads_per_frequency]);
}

int rig_init(RigState *s, char *msg, size_t n)
{
    if (s->b[B_speed_control]) {
        /* the shaft starts at the speed setpoint (a replay starts at the measured speed) */
        if (!isfinite(s->r[R_w_set])) {
            snprintf(msg, n, "input w_set = %g: must be finite", s->r[R_w_set]);
            return 1;
        }
        s->r[R_w] = s->r[R_w_set];
    } else {
        s->r[R_w] = s->r[R_w_start];
    }
    s->r[R_frequency] = s->r[R_w] == 0 ? 0.0 : s->r[R_w] * s->i[I_pole_pairs] / (2 * PI);
    s->r[R_T_em] = torque(s, s->r[R_w], s->r[R_frequency]);
    if (s->b[B_speed_control]) {         /* held at the setpoint: the motor carries the shaft */
        if (!isfinite(s->r[R_tau_shaft])) {
            snprintf(msg, n, "input tau_shaft = %g: must be finite", s->r[R_tau_shaft]);
            return 1;
        }
        s->r[R_T_em] = s->r[R_tau_shaft];
        s->r[R_alpha] = 0.0;
    }
    s->r[R_P_mech] = s->r[R_T_em] * s->r[R_w];
    return 0;
}

/* motor.InductionMotor._speed_step: the closed speed loop as a first-order lag of time
 * constant tc, solved exactly over the step with w_set held; T_em = tau + (J + J_side) alpha */
static int speed_step(RigState *s, double h, double tau, double J_acc, double J_dec,
                      char *msg, size_t n)
{
    double w_set = s->r[R_w_set], tc = s->r[R_speed_time_constant], w, alpha, J;
    if (!isfinite(w_set)) {
        snprintf(msg, n, "input w_set = %g: must be finite", w_set);
        return 1;
    }
    w = w_set + (s->r[R_w] - w_set) * exp(-h / tc);
    alpha = (w_set - w) / tc;
    J = s->r[R_J] + (((alpha >= 0) == (w >= 0)) ? J_acc : J_dec);
    s->r[R_w] = w;
    s->r[R_alpha] = alpha;
    s->r[R_T_em] = tau + J * alpha;
    s->r[R_frequency] = w * s->i[I_pole_pairs] / (2 * PI);
    s->r[R_P_mech] = s->r[R_T_em] * w;
    if (!isfinite(s->r[R_P_mech])) {
        snprintf(msg, n, "tau_shaft = %g N.m gives a torque that is not a finite number: "
                 "refused", tau);
        return 1;
    }
    return 0;
}

int rig_step(RigState *s, double t, double h, char *msg, size_t n)
{
    double tau = s->r[R_tau_shaft], J_acc = s->r[R_J_load], J_dec = s->r[R_J_load_dec];
    double hh, inv_acc, inv_dec, w, f, df, s0, s1, T_em, r;
    int k, steps;
    if (!(isfinite(tau) && isfinite(J_acc) && J_acc >= 0 && isfinite(J_dec))) {
        snprintf(msg, n, "inputs tau_shaft = %g, J_load = %g, J_load_dec = %g: must be finite, "
                 "J_load not negative", tau, J_acc, J_dec);
        return 1;
    }
    if (J_dec < 0) J_dec = J_acc;
    if (s->b[B_speed_control]) return speed_step(s, h, tau, J_acc, J_dec, msg, n);
    steps = (int)ceil(h / SUBSTEP - 1e-9);
    if (steps < 1) steps = 1;
    hh = h / steps;
    inv_acc = 1.0 / (s->r[R_J] + J_acc);
    inv_dec = 1.0 / (s->r[R_J] + J_dec);
    w = s->r[R_w];
    f = s->r[R_frequency];
    df = s->r[R_ramp_rate] * hh;
    s0 = setpoint(s, t);
    s1 = setpoint(s, t + h);
    for (k = 0; k < steps; k++) {
        double target = s0 == s1 ? s0 : setpoint(s, t + k * hh);
        f = fabs(target - f) <= df ? target : f + copysign(df, target - f);
        r = torque(s, w, f) - tau;
        w += hh * r * (((r >= 0) == (w >= 0)) ? inv_acc : inv_dec);
    }
    s->r[R_w] = w;
    s->r[R_frequency] = f;
    T_em = torque(s, w, f);
    r = T_em - tau;
    s->r[R_alpha] = r * (((r >= 0) == (w >= 0)) ? inv_acc : inv_dec);
    s->r[R_T_em] = T_em;
    s->r[R_P_mech] = T_em * w;
    return 0;
}

int rig_state_valid(const RigState *s)
{
    return s->phase != RIG_PH_STEP || (s->x[X_DWK] > 0 && s->x[X_C_SYNC] > 0);
}
