/* Native transducer (Transducer, TorqueTransducer, SpeedTransducer: the same code, the units
 * are the model description's): first-order bandwidth, gain and offset errors, a zero drifting
 * in time and with the temperature input, white noise, quantisation; the C twin of
 * cyclo_fmu/slaves/transducer.py, model_core.rig.Transducer and rig.zero_drift_per_10K. */
#include <math.h>
#include <stdio.h>

#include "rig_model.h"

#define PI 3.141592653589793
/* [K] model_core.effects.T_STEP and model_core.rig.TRANSDUCER_T_RANGE */
#define T_STEP 10.0
#define T_LO 173.15
#define T_HI 473.15

/* x[]: filtered value, index of the next noise sample, step size and filter coefficient of
 * the last step (has_dt: 0 before the first step) */
enum { X_FILTERED, X_NEXT, X_DT, X_A, X_HAS_DT };

int rig_setup(RigState *s, char *msg, size_t n)
{
    static const int reals[] = {R_scale, R_gain_error, R_offset, R_bandwidth, R_noise,
                                R_resolution, R_zero_drift, R_zero_drift_tau, R_zero_per_10K};
    static const char *const names[] = {"scale", "gain_error", "offset", "bandwidth", "noise",
                                        "resolution", "zero_drift", "zero_drift_tau",
                                        "zero_per_10K"};
    int j;
    for (j = 0; j < 9; j++)
        if (!isfinite(s->r[reals[j]])) {
            snprintf(msg, n, "%s = %g: must be finite", names[j], s->r[reals[j]]);
            return 1;
        }
    if (s->r[R_noise] < 0) {
        snprintf(msg, n, "noise = %g: must not be negative", s->r[R_noise]);
        return 1;
    }
    if (s->i[I_seed] < 0) {
        snprintf(msg, n, "seed = %d: must not be negative", s->i[I_seed]);
        return 1;
    }
    return 0;
}

/* 0, or 1 with a message: the temperature input is read while zero_per_10K is not 0 */
static int check_temperature(const RigState *s, char *msg, size_t n)
{
    double T = s->r[R_temperature];
    if (s->b[B_ideal] || !s->r[R_zero_per_10K] || (T >= T_LO && T <= T_HI)) return 0;
    snprintf(msg, n, "temperature = %g K: must be a temperature between %g and %g K while "
             "zero_per_10K = %g is not 0 (a temperature in degC needs + 273.15; a master that "
             "starts its connections at 0 must initialise this one)", T, T_LO, T_HI,
             s->r[R_zero_per_10K]);
    return 1;
}

static void read_out(RigState *s, double elapsed)
{
    double y;
    if (s->b[B_ideal]) {
        s->r[R_y] = s->r[R_scale] * s->r[R_x];
        return;
    }
    /* the zero's drift at the step's end and at the temperature input (slaves/transducer.py;
     * rig.zero_drift_per_10K: c (T - T_ref)/10 K), added to the offset */
    double drift = s->r[R_zero_drift] ? s->r[R_zero_drift]
        * (1.0 - exp(-elapsed / s->r[R_zero_drift_tau])) : 0.0;
    if (s->r[R_zero_per_10K])
        drift = drift + s->r[R_zero_per_10K] * (s->r[R_temperature] - s->r[R_zero_T_ref])
            / T_STEP;
    y = s->x[X_FILTERED] * (1 + s->r[R_gain_error]) + (s->r[R_offset] + drift)
        + s->r[R_noise] * rig_normal_sample((unsigned long long)s->i[I_seed],
                                            (unsigned long long)s->x[X_NEXT]);
    s->x[X_NEXT] += 1.0;
    if (s->r[R_resolution] > 0) {
        /* Python's round() gives an integer (ties to even, as nearbyint here), which has no
         * negative zero: a reading that rounds to zero is +0, not -0 */
        double q = nearbyint(y / s->r[R_resolution]);
        if (q == 0.0) q = 0.0;
        y = s->r[R_resolution] * q;
    }
    s->r[R_y] = y;
}

int rig_init(RigState *s, char *msg, size_t n)
{
    if (!isfinite(s->r[R_x])) {
        snprintf(msg, n, "input x = %g: must be finite", s->r[R_x]);
        return 1;
    }
    if (check_temperature(s, msg, n)) return 1;
    s->x[X_NEXT] = 0.0;                 /* the same first draws at every evaluation */
    s->x[X_FILTERED] = s->r[R_scale] * s->r[R_x];
    s->x[X_HAS_DT] = 0.0;
    s->x[X_DT] = s->x[X_A] = 0.0;
    read_out(s, 0.0);
    return 0;
}

int rig_step(RigState *s, double t, double h, char *msg, size_t n)
{
    double x = s->r[R_x], a;
    if (!isfinite(x)) {
        snprintf(msg, n, "input x = %g: must be finite", x);
        return 1;
    }
    if (check_temperature(s, msg, n)) return 1;
    if (!s->x[X_HAS_DT] || h != s->x[X_DT]) {   /* the coefficient of this step size, once */
        s->x[X_DT] = h;
        s->x[X_HAS_DT] = 1.0;
        s->x[X_A] = s->r[R_bandwidth] > 0 ? exp(-2 * PI * s->r[R_bandwidth] * h) : 0.0;
    }
    a = s->x[X_A];
    s->x[X_FILTERED] = a * s->x[X_FILTERED] + (1 - a) * s->r[R_scale] * x;
    read_out(s, t + h);
    return 0;
}

int rig_state_valid(const RigState *s)
{
    return s->x[X_NEXT] >= 0 && s->x[X_NEXT] < 9007199254740992.0
        && s->x[X_NEXT] == floor(s->x[X_NEXT]);
}
