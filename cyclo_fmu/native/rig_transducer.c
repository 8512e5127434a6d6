/* Native transducer (Transducer, TorqueTransducer, SpeedTransducer: the same code, the units
 * are the model description's): first-order bandwidth, gain and offset errors, white noise,
 * quantisation; the C twin of cyclo_fmu/slaves/transducer.py and model_core.rig.Transducer. */
#include <math.h>
#include <stdio.h>

#include "rig_model.h"

#define PI 3.141592653589793

/* x[]: filtered value, index of the next noise sample, step size and filter coefficient of
 * the last step (has_dt: 0 before the first step) */
enum { X_FILTERED, X_NEXT, X_DT, X_A, X_HAS_DT };

int rig_setup(RigState *s, char *msg, size_t n)
{
    static const int reals[] = {R_scale, R_gain_error, R_offset, R_bandwidth, R_noise,
                                R_resolution, R_zero_drift, R_zero_drift_tau};
    static const char *const names[] = {"scale", "gain_error", "offset", "bandwidth", "noise",
                                        "resolution", "zero_drift", "zero_drift_tau"};
    int j;
    for (j = 0; j < 8; j++)
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

static void read_out(RigState *s, double elapsed)
{
    double y;
    if (s->b[B_ideal]) {
        s->r[R_y] = s->r[R_scale] * s->r[R_x];
        return;
    }
    /* the zero's drift at the step's end (slaves/transducer.py), added to the offset */
    double drift = s->r[R_zero_drift] ? s->r[R_zero_drift]
        * (1.0 - exp(-elapsed / s->r[R_zero_drift_tau])) : 0.0;
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
