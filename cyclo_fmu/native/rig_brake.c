/* Native FeltBrake: felt friction brake, optionally on a compliant coupling with a drum, the
 * C twin of cyclo_fmu/slaves/brake.py and model_core.rig.felt_brake_torque /
 * coupled_drum_step (same arithmetic, same order). */
#include <math.h>
#include <stdio.h>

#include "rig_model.h"

#define COUPLING_SUBSTEP 2.5e-4   /* s; model_core.rig.COUPLING_SUBSTEP */

static const int SCHED_T[8] = {R_schedule_time_1, R_schedule_time_2, R_schedule_time_3,
                               R_schedule_time_4, R_schedule_time_5, R_schedule_time_6,
                               R_schedule_time_7, R_schedule_time_8};
static const int SCHED_V[8] = {R_schedule_value_1, R_schedule_value_2, R_schedule_value_3,
                               R_schedule_value_4, R_schedule_value_5, R_schedule_value_6,
                               R_schedule_value_7, R_schedule_value_8};

enum { X_TWIST, X_W_DRUM, X_C };

static double felt(double w, double setpoint, double w_reg)
{
    return setpoint * tanh(w / w_reg);
}

int rig_setup(RigState *s, char *msg, size_t n)
{
    static const int positive[] = {R_w_reg, R_k_coupling, R_zeta_coupling};
    static const char *const names[] = {"w_reg", "k_coupling", "zeta_coupling"};
    double times[8], values[8];
    int j;
    for (j = 0; j < 8; j++) { times[j] = s->r[SCHED_T[j]]; values[j] = s->r[SCHED_V[j]]; }
    if (rig_load_schedule(s, "torque_schedule", s->s[S_torque_schedule],
                          s->i[I_schedule_points], times, values, msg, n))
        return 1;
    if (s->i[I_T_count] < 1) {
        snprintf(msg, n, "T_count = %d: must be at least 1", s->i[I_T_count]);
        return 1;
    }
    if (s->r[R_T_first] < 0 || s->r[R_T_last] < 0) {
        snprintf(msg, n, "T_first, T_last: a brake torque setpoint must not be negative");
        return 1;
    }
    for (j = 0; j < 3; j++) {
        double v = s->r[positive[j]];
        if (!(isfinite(v) && v > 0)) {
            snprintf(msg, n, "%s = %g: must be positive", names[j], v);
            return 1;
        }
    }
    if (!(isfinite(s->r[R_J_out]) && s->r[R_J_out] >= 0)) {
        snprintf(msg, n, "J_out = %g: must not be negative", s->r[R_J_out]);
        return 1;
    }
    if (s->b[B_torque_control] && s->r[R_J_out] != 0) {
        snprintf(msg, n, "J_out = %g: must be 0 with torque_control (the controlled torque "
                 "acts at the shaft)", s->r[R_J_out]);
        return 1;
    }
    for (j = 0; j < s->n_schedule; j++)
        if (s->schedule[j][1] < 0) {
            snprintf(msg, n, "torque schedule: a brake torque setpoint must not be negative");
            return 1;
        }
    s->x[X_C] = 2 * s->r[R_zeta_coupling] * sqrt(s->r[R_k_coupling] * s->r[R_J_out]);
    return 0;
}

static double setpoint(const RigState *s, double t)
{
    if (s->n_schedule > 0) return rig_schedule_value(s, t);
    return rig_series_value(t, s->r[R_T_first], s->r[R_T_last], s->i[I_T_count],
                            s->r[R_hold_time], 1);
}

static int update(RigState *s, double t, double dt, char *msg, size_t n)
{
    double w = s->r[R_w], sp, Ts, Tb;
    double k = s->r[R_k_coupling], c = s->x[X_C], J = s->r[R_J_out], w_reg = s->r[R_w_reg];
    if (!isfinite(w)) {
        snprintf(msg, n, "input w = %g: must be finite", w);
        return 1;
    }
    if (s->b[B_torque_control]) {    /* a load machine: the input torque at the shaft */
        double T = s->r[R_T_set];
        if (!isfinite(T)) {
            snprintf(msg, n, "input T_set = %g: must be finite", T);
            return 1;
        }
        s->r[R_T_brake] = s->r[R_torque_shaft] = T;
        s->r[R_tau_out] = -T;
        return 0;
    }
    sp = setpoint(s, t);
    if (J == 0) {
        Ts = Tb = felt(w, sp, w_reg);
    } else if (dt > 0) {
        /* model_core.rig.coupled_drum_step */
        double th = s->x[X_TWIST], wd = s->x[X_W_DRUM], h;
        int j, steps = (int)ceil(dt / COUPLING_SUBSTEP - 1e-9);
        if (steps < 1) steps = 1;
        for (j = 0; j < steps; j++) {
            double dTb;
            h = dt / steps;
            Ts = k * th + c * (w - wd);
            Tb = felt(wd, sp, w_reg);
            dTb = sp ? sp / w_reg / pow(cosh(wd / w_reg), 2.0) : 0.0;
            wd = wd + h * (Ts - Tb) / (J + h * (dTb + c));
            th = th + h * (w - wd);
        }
        Ts = k * th + c * (w - wd);
        Tb = felt(wd, sp, w_reg);
        s->x[X_TWIST] = th;
        s->x[X_W_DRUM] = wd;
    } else {
        Ts = k * s->x[X_TWIST] + c * (w - s->x[X_W_DRUM]);
        Tb = felt(s->x[X_W_DRUM], sp, w_reg);
    }
    s->r[R_T_brake] = Tb;
    s->r[R_torque_shaft] = Ts;
    s->r[R_tau_out] = -Ts;
    return 0;
}

int rig_init(RigState *s, char *msg, size_t n)
{
    if (!isfinite(s->r[R_w])) {
        snprintf(msg, n, "input w = %g: must be finite", s->r[R_w]);
        return 1;
    }
    s->x[X_W_DRUM] = s->r[R_w];     /* the drum starts with the shaft, untwisted */
    s->x[X_TWIST] = 0.0;
    return update(s, 0.0, 0.0, msg, n);
}

int rig_step(RigState *s, double t, double h, char *msg, size_t n)
{
    /* the setpoint of the step's start (a step in the setpoint acts from its time on) */
    return update(s, t, h, msg, n);
}

int rig_state_valid(const RigState *s)
{
    return s->x[X_C] >= 0;
}
