/* Cycloid drive, native FMU: the FMI 2.0 co-simulation interface.
 *
 * One instance holds a CDState (plain data, no pointers: it is what fmi2GetFMUstate copies and
 * fmi2SerializeFMUstate writes) and the host's callbacks. The physics is in cd_model.c, the
 * design's loss map in the generated cd_map_data.c. Written for cyclo-fmu (MIT license); the
 * FMI headers are the Modelica Association's (2-clause BSD).
 *
 * Value references (modelDescription.xml is generated with the same numbers by
 * cyclo_fmu/native/build.py):
 *   Real     0 w_in, 1 tau_out, 2 alpha_in, 3 T_oil_in (inputs)
 *            10..29 outputs, in the order of OUT_NAMES
 *            30..49 extra physics parameters, in the order of CDExtra (its first 20)
 *            60..71 its fields 20..31 (the ripple at 2x, output 1x and 2x), 72 its field
 *            32 (stribeck_transition), 73 its field 33 (thermal_T_scale), 74 its field
 *            34 (loss_transition)
 *            50 J_out, 51 alpha_ref (parameters of the output inertia)
 *            52 PL_mesh (output: the calibrated mesh loss; out[O_PL_MESH])
 *            53 T_oil, 54 Q_ambient (outputs of the temperature)
 *            55..59 the heat balance's parameters (CD_DEFAULT_THERMAL's order)
 *            100.. constants of the design (generated table)
 *   Integer  0 mode_number; 100.. constants
 *   Boolean  10 locked, 11 use_T_oil_input
 *   String   0 mode; 100.. constants
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "cd_model.h"

#define VR_W_IN 0
#define VR_TAU_OUT 1
#define VR_ALPHA_IN 2
#define VR_T_OIL_IN 3
#define VR_T_OIL 53
#define VR_Q_AMBIENT 54
#define VR_THERMAL0 55
#define VR_USE_T_OIL 11
#define N_OUT_ALL (N_OUT + 3)  /* out[]: the 20, PL_mesh, T_oil, Q_ambient */
/* K, the grease temperatures accepted (cycloid_drive.T_OIL_RANGE: -100 to 200 degC) */
#define T_OIL_MIN 173.15
/* K, the smallest temperature scale of the warm-up's exponential law (model_core.thermal.
 * T_SCALE_MIN; 0 is the linear law) */
#define CD_T_SCALE_MIN 1.0
#define T_OIL_MAX 473.15
#define VR_OUT0 10
#define N_OUT 20               /* outputs at value references 10..29 */
#define VR_PL_MESH 52          /* one more output, beyond them */
#define VR_EXTRA0 30
#define N_EXTRA_FIRST 20       /* CDExtra's fields at 30..49; the others from VR_EXTRA1 */
#define VR_EXTRA1 60
#define VR_J_OUT 50
#define VR_ALPHA_REF 51
/* rad/s^2, default of alpha_ref (CycloidDrive.ALPHA_REF: 2 pi 25, the regulator's ramp on the
 * two-pole motor) */
#define ALPHA_REF_DEFAULT (2 * 3.14159265358979311600 * 25.0)
/* relative change of w_in and tau_out within which a step reuses the last J_load
 * (CycloidDrive._SLOPE_REUSE) */
#define SLOPE_REUSE 1e-3
#define VR_MODE_NUMBER 0
#define VR_LOCKED 10
#define VR_MODE 0

enum { O_W_OUT, O_TAU_IN, O_TAU_HOUSING, O_P_LOSS, O_PL1, O_PL2, O_PL3, O_PL5, O_PL6, O_ETA,
       O_ETA0, O_P_EXTRA, O_P_STORED, O_PL_SUPPORT, O_PL_SEAL, O_PL_CHURN, O_TORQUE_OUT,
       O_TAU_IN_STATIC, O_J_LOAD, O_J_LOAD_DEC, O_PL_MESH, O_T_OIL, O_Q_AMBIENT };

static const char *const THERMAL_NAMES[CD_N_THERMAL] = {
    "T_oil_start", "ambient_temperature", "housing_heat_capacity", "housing_heat_transfer",
    "housing_area"};

static const char *const EXTRA_NAMES[CD_N_EXTRA] = {
    "drag_torque", "stribeck_torque", "stribeck_speed", "input_inertia", "ripple_1x",
    "ripple_1x_phase", "ripple_roller", "ripple_roller_phase", "thermal_loss_change",
    "thermal_tau", "drag_exponent", "stribeck_exponent", "run_in_change", "run_in_distance",
    "ripple_1x_load", "ripple_1x_load_phase", "ripple_roller_load", "ripple_roller_load_phase",
    "thermal_loss_per_10K", "thermal_T_ref", "ripple_2x", "ripple_2x_phase", "ripple_2x_load",
    "ripple_2x_load_phase", "ripple_out_1x", "ripple_out_1x_phase", "ripple_out_1x_load",
    "ripple_out_1x_load_phase", "ripple_out_2x", "ripple_out_2x_phase", "ripple_out_2x_load",
    "ripple_out_2x_load_phase", "stribeck_transition", "thermal_T_scale",
    "loss_transition"};

/* index into CDExtra of a value reference, or -1 */
static int extra_index(fmi2ValueReference r)
{
    if (r >= VR_EXTRA0 && r < VR_EXTRA0 + N_EXTRA_FIRST) return (int)(r - VR_EXTRA0);
    if (r >= VR_EXTRA1 && r < VR_EXTRA1 + (CD_N_EXTRA - N_EXTRA_FIRST))
        return N_EXTRA_FIRST + (int)(r - VR_EXTRA1);
    return -1;
}

#define STATE_MAGIC 0x43444e53u   /* "CDNS" */
#define STATE_VERSION 10u   /* 3: PL_mesh (calibration); 4: CDExtra.stribeck_exponent, run-in,
                              * load ripple, CDState.distance; 5: the oil temperature;
                              * 6: CDExtra's warm-up per 10 K; 7: the ripple at 2x, output
                              * 1x and 2x; 8: CDExtra.stribeck_transition;
                              * 9: CDExtra.thermal_T_scale;
                              * 10: CDExtra.loss_transition */

/* Everything that defines the instance's behaviour from here on: inputs, parameters,
 * outputs and the dynamic state. Plain data: copied and serialised as it is. */
typedef struct {
    unsigned int magic, version;
    int phase;
    double w_in, tau_out, alpha_in;
    double J_out, alpha_ref;   /* output inertia (kg m^2) and the secants' acceleration */
    int mode;              /* index of the String parameter "mode" (0..5) */
    int mode_number;       /* 0 = use mode, 1..6 */
    CDExtra extra;
    double out[N_OUT_ALL];     /* the outputs at 10..29, then PL_mesh, T_oil, Q_ambient */
    double T_oil_in;           /* input: grease temperature from outside, K */
    int use_T_oil_input;       /* parameter: the input (1) or the heat balance (0) */
    double thermal[CD_N_THERMAL];   /* the heat balance's parameters (CD_DEFAULT_THERMAL) */
    double T;                  /* grease/housing temperature at the last point, K */
    int locked;
    int mode_eff;          /* resolved at exitInitializationMode */
    double theta;          /* angle of the driving shaft since the start, rad */
    double distance;       /* angle it travelled (integral of |w_in|), rad: the run-in's */
    double w_last;         /* driving speed at the last step, rad/s */
    int has_w_last;
    double t_start;
    int warned_range;
    int has_key;           /* the last J_load secants and where they were taken */
    double key_w, key_tau, key_J_acc, key_J_dec;
} CDState;

/* the FMI 2.0 front shared with the bench components (instances, logging, phases, the
 * model-independent calls): fmi2_front.h */
#define FRONT_STATE CDState
#define FRONT_GUID CD_GUID
#define FRONT_GUID_BYTES 40
#define FRONT_BOTH_ALLOCATORS
#include "fmi2_front.h"

enum { PH_INSTANTIATED = FRONT_PH_INSTANTIATED, PH_INIT = FRONT_PH_INIT,
       PH_STEP = FRONT_PH_STEP, PH_TERMINATED = FRONT_PH_TERMINATED };

static void set_defaults(CDState *s)
{
    memset(s, 0, sizeof *s);
    s->magic = STATE_MAGIC;
    s->version = STATE_VERSION;
    s->phase = PH_INSTANTIATED;
    s->mode = 3;   /* "S1", the bench's mode (the Python FMU's default) */
    s->mode_number = 0;
    s->extra = CD_DEFAULT_EXTRA;
    s->alpha_ref = ALPHA_REF_DEFAULT;
    s->out[O_ETA0] = 1.0;
    memcpy(s->thermal, CD_DEFAULT_THERMAL, sizeof s->thermal);
    s->T_oil_in = s->T = s->out[O_T_OIL] = CD_DEFAULT_THERMAL[0];
}

/* NULL if a heat-balance parameter's value is acceptable, else why not */
static const char *thermal_problem(int i, double v)
{
    if (!isfinite(v)) return "must be a finite number";
    if (i < 2) return (v > T_OIL_MIN && v < T_OIL_MAX) ? NULL
                      : "must lie between 173.15 and 473.15 K (-100 to 200 degC)";
    return v > 0 ? NULL : "must be positive";
}

static int resolve_mode(const CDState *s)
{
    return s->mode_number ? s->mode_number - 1 : s->mode;
}

static double *extra_field(CDExtra *x, int i)
{
    double *f[CD_N_EXTRA];
    f[0] = &x->drag_torque; f[1] = &x->stribeck_torque; f[2] = &x->stribeck_speed;
    f[3] = &x->input_inertia; f[4] = &x->ripple_1x; f[5] = &x->ripple_1x_phase;
    f[6] = &x->ripple_roller; f[7] = &x->ripple_roller_phase; f[8] = &x->thermal_loss_change;
    f[9] = &x->thermal_tau; f[10] = &x->drag_exponent; f[11] = &x->stribeck_exponent;
    f[12] = &x->run_in_change; f[13] = &x->run_in_distance; f[14] = &x->ripple_1x_load;
    f[15] = &x->ripple_1x_load_phase; f[16] = &x->ripple_roller_load;
    f[17] = &x->ripple_roller_load_phase; f[18] = &x->thermal_loss_per_10K;
    f[19] = &x->thermal_T_ref; f[20] = &x->ripple_2x; f[21] = &x->ripple_2x_phase;
    f[22] = &x->ripple_2x_load; f[23] = &x->ripple_2x_load_phase; f[24] = &x->ripple_out_1x;
    f[25] = &x->ripple_out_1x_phase; f[26] = &x->ripple_out_1x_load;
    f[27] = &x->ripple_out_1x_load_phase; f[28] = &x->ripple_out_2x;
    f[29] = &x->ripple_out_2x_phase; f[30] = &x->ripple_out_2x_load;
    f[31] = &x->ripple_out_2x_load_phase; f[32] = &x->stribeck_transition;
    f[33] = &x->thermal_T_scale; f[34] = &x->loss_transition;
    return f[i];
}

/* NULL if the value is acceptable, else why not (design.validate_design's rules) */
static const char *extra_problem(int i, double v)
{
    if (!isfinite(v)) return "must be a finite number";
    switch (i) {
    case 0: case 1: case 3: case 32:   /* case 32: the reversal's width, 0 = a sharp sign */
    case 34:   /* the losses' transition width through standstill, 0 = the losses at full value */
    case 20: case 22: case 24: case 26: case 28: case 30:   /* the ripples' amplitudes */
        return v < 0 ? "must not be negative" : NULL;
    case 2: case 9:
        return v > 0 ? NULL : "must be positive";
    case 8:   /* the losses cannot fall below zero when warm (keeps P_loss >= 0) */
        return v >= -1 ? NULL : "must not be below -1";
    case 10:
        return (v >= 0 && v <= 2) ? NULL : "must lie between 0 and 2";
    case 11:
        return (v >= 1 && v <= 2) ? NULL : "must lie between 1 (Tustin) and 2 (Gaussian)";
    case 12:
        return v >= -1 ? NULL : "must be at least -1";
    case 13:
        return v > 0 ? NULL : "must be positive";
    case 19:
        return (v > T_OIL_MIN && v < T_OIL_MAX) ? NULL
               : "must lie between 173.15 and 473.15 K (-100 to 200 degC)";
    case 33:   /* model_core.thermal.T_SCALE_MIN */
        return (v == 0.0 || v >= CD_T_SCALE_MIN) ? NULL
               : "must be 0 (the linear law) or at least 1 K";
    default:
        return NULL;
    }
}

/* any ripple at 2x, output 1x or 2x (CycloidDrive._shaft_ripple) */
static int shaft_ripple(const CDExtra *x)
{
    return x->ripple_2x != 0 || x->ripple_2x_load != 0 || x->ripple_out_1x != 0
           || x->ripple_out_1x_load != 0 || x->ripple_out_2x != 0 || x->ripple_out_2x_load != 0;
}

/* CycloidDrive._gear_torque (map): the driving-shaft torque of the gear at a load torque */
static double gear_torque(const CDExtra *x, int mode, double w_in, double tau_out, double T)
{
    CDSolution r;
    double lossless = -tau_out * CD_MAP.modes[mode].ratio_out;
    cd_solve_thermal(&CD_THERMAL, mode, w_in, tau_out, T, &r);
    /* the losses through standstill, as evaluate() scales them (1 at loss_transition 0) */
    if (x->loss_transition == 0) return r.torques[CD_MAP.modes[mode].a];
    return lossless + cd_loss_transition(x, w_in) * (r.torques[CD_MAP.modes[mode].a] - lossless);
}

/* CycloidDrive._solve's output inertia: J_load and J_load_dec, secants of the driving torque
 * over +-alpha_ref (reused while w_in and the load stay within SLOPE_REUSE), and
 * tau_in_static. commit = 0 (Initialization Mode's reads) neither uses nor keeps the secants. */
static void output_inertia(CDState *s, int mode, double tau_ext, double J_r, double tau_in_gear,
                           int commit, double T)
{
    double w_in = s->w_in, static_, J_acc, J_dec;
    if (J_r == 0.0) {
        s->out[O_TAU_IN_STATIC] = s->out[O_TAU_IN];
        s->out[O_J_LOAD] = s->out[O_J_LOAD_DEC] = 0.0;
        return;
    }
    static_ = gear_torque(&s->extra, mode, w_in, tau_ext, T);
    if (commit && s->has_key && fabs(w_in - s->key_w) <= SLOPE_REUSE * fabs(s->key_w)
        && fabs(tau_ext - s->key_tau) <= SLOPE_REUSE * fabs(s->key_tau)) {
        J_acc = s->key_J_acc;
        J_dec = s->key_J_dec;
    } else {
        double A = w_in >= 0 ? s->alpha_ref : -s->alpha_ref;   /* speeding up */
        double lossless = J_r * CD_MAP.modes[mode].ratio_out;
        J_acc = (gear_torque(&s->extra, mode, w_in, tau_ext - J_r * A, T) - static_) / A;
        J_dec = (static_ - gear_torque(&s->extra, mode, w_in, tau_ext + J_r * A, T)) / A;
        /* locked: the lossless reflection */
        if (!(isfinite(J_acc) && J_acc > 0)) J_acc = lossless;
        if (!(isfinite(J_dec) && J_dec > 0)) J_dec = lossless;
        if (commit) {
            s->has_key = 1;
            s->key_w = w_in;
            s->key_tau = tau_ext;
            s->key_J_acc = J_acc;
            s->key_J_dec = J_dec;
        }
    }
    s->out[O_J_LOAD] = J_acc;
    s->out[O_J_LOAD_DEC] = J_dec;
    s->out[O_TAU_IN_STATIC] = s->out[O_TAU_IN] - (tau_in_gear - static_);
}

/* CycloidDrive._update: outputs at time t after a step dt. commit = 0 evaluates without
 * touching the dynamic state (Initialization Mode's outputs). */
static void evaluate(Instance *c, double t, double dt, int commit)
{
    CDState *s = &c->s;
    const CDMode *m;
    CDSolution r;
    int mode = commit || s->phase == PH_STEP ? s->mode_eff : resolve_mode(s);
    double J_r = s->J_out * CD_MAP.modes[mode].ratio_out;
    /* the load including the output inertia's torque */
    double tau_ext = s->tau_out, tau_out = tau_ext - J_r * s->alpha_in;
    double tau_in, tau_in_gear, p_in, p_out, p_stored = 0.0, w_in = s->w_in;
    int steady = s->extra.drag_torque != 0 || s->extra.stribeck_torque != 0
                 || CD_N_DISCOVERED > 0;
    int dynamic = s->extra.input_inertia != 0 || s->extra.ripple_1x != 0
                  || s->extra.ripple_roller != 0 || s->extra.thermal_loss_change != 0
                  || s->extra.run_in_change != 0 || s->extra.ripple_1x_load != 0
                  || s->extra.ripple_roller_load != 0 || s->extra.thermal_loss_per_10K != 0
                  || shaft_ripple(&s->extra);
    int transition = s->extra.loss_transition != 0;
    /* CycloidDrive._temperature: the input, or the heat balance stepped with the loss at the
     * step's start held over the step: the step's inputs at the temperature of its start
     * (CycloidDrive._loss_at_start: evaluated without a step of the dynamic terms) */
    double R = 1.0 / (s->thermal[3] * s->thermal[4]), T;
    if (s->use_T_oil_input)
        T = s->T_oil_in;
    else if (dt > 0) {
        CDState saved = *s;
        double P0;
        evaluate(c, t - dt, 0.0, 0);
        P0 = s->out[O_P_LOSS];
        saved.warned_range = s->warned_range;   /* a warning the probe gave stays given */
        *s = saved;
        T = cd_housing_step(s->T, P0, dt, s->thermal[1], s->thermal[2], R);
    } else
        T = s->phase == PH_STEP ? s->T : s->thermal[0];
    if (!(T > T_OIL_MIN && T < T_OIL_MAX)) {
        logmsg(c, fmi2Error, "%s %g K: must be a temperature between 173.15 and 473.15 K "
               "(-100 to 200 degC)", s->use_T_oil_input ? "T_oil_in =" : "the heat balance's "
               "grease temperature left the range:", T);
        s->out[O_P_LOSS] = NAN;   /* refused by the caller (outputs_finite) */
        return;
    }
    if (commit) s->T = T;
    s->out[O_T_OIL] = T;
    s->out[O_Q_AMBIENT] = (T - s->thermal[1]) / R;
    m = &CD_MAP.modes[mode];
    /* CycloidDrive._loss_T: one warm-up. A warm-up in time (thermal_loss_change) or per 10 K
     * (thermal_loss_per_10K) was fitted against the model at one temperature: with it the
     * losses stay at T_oil_start */
    if (s->extra.thermal_loss_change != 0 || s->extra.thermal_loss_per_10K != 0)
        T = s->thermal[0];
    cd_solve_thermal(&CD_THERMAL, mode, w_in, tau_out, T, &r);
    if (r.out_of_range && !s->warned_range
        && (fabs(tau_out) > CD_MAP_TORQUE_MAX || fabs(w_in) > CD_MAP_SPEED_MAX)) {
        s->warned_range = 1;
        logmsg(c, fmi2Warning, "operating point |tau_out| = %g N.m, |w_in| = %g rad/s beyond "
               "the loss map this FMU was built with (|tau_out| <= %g N.m, |w_in| <= %g rad/s): "
               "eta0 is held at the map's edge; build the FMU with a larger map for such loads "
               "(reported once)", fabs(tau_out), fabs(w_in), CD_MAP_TORQUE_MAX,
               CD_MAP_SPEED_MAX);
    }
    s->out[O_W_OUT] = r.speeds[m->b];
    if (transition) {
        /* the losses through standstill (ExtraPhysics.loss_transition_share): the loss torque
         * beyond the lossless one and every partial loss times tanh(|w_in|/w_c) */
        double share = cd_loss_transition(&s->extra, w_in), lossless = -tau_out * m->ratio_out;
        int i;
        r.torques[m->a] = lossless + share * (r.torques[m->a] - lossless);
        for (i = 0; i < CD_N_LOSSES; i++) r.losses[i] = share * r.losses[i];
    }
    tau_in = tau_in_gear = r.torques[m->a];
    s->out[O_PL1] = r.losses[0];
    s->out[O_PL2] = r.losses[1];
    s->out[O_PL3] = r.losses[2];
    s->out[O_PL5] = r.losses[3];
    s->out[O_PL6] = r.losses[4];
    s->out[O_PL_SUPPORT] = r.losses[5];
    s->out[O_PL_SEAL] = r.losses[6];
    s->out[O_PL_CHURN] = r.losses[7];
    s->out[O_PL_MESH] = r.losses[8];
    if (steady) tau_in += cd_steady_torque(&s->extra, w_in);
    if (CD_N_DISCOVERED > 0)   /* design [[extra.discovered]] */
        tau_in += cd_discovered_torque(CD_DISCOVERED, CD_N_DISCOVERED, w_in, tau_out);
    double inertia = 0.0;   /* input_inertia's torque: stored in the shaft, not reacted */
    if (dynamic) {
        /* CycloidDrive._dynamic_torque */
        double alpha = (!s->has_w_last || dt <= 0) ? 0.0 : (w_in - s->w_last) / dt;
        double theta = s->theta, distance = s->distance, loss_in, dyn;
        if (dt > 0) theta += w_in * dt;
        if (dt > 0) distance += fabs(w_in) * dt;
        if (commit && (dt > 0 || !s->has_w_last)) {
            s->theta = theta;
            s->distance = distance;
            s->w_last = w_in;
            s->has_w_last = 1;
        }
        loss_in = tau_in_gear + tau_out * m->ratio_out;   /* minus the lossless torque */
        dyn = cd_dynamic_torque(&s->extra, alpha, theta, m->order, t - s->t_start, loss_in);
        inertia = s->extra.input_inertia * alpha;
        /* the conservative part (inertia, ripples: d/dt of an energy), not a loss */
        p_stored = cd_dynamic_torque(&s->extra, alpha, theta, m->order, 0.0, 0.0);
        if (s->extra.ripple_1x_load != 0 || s->extra.ripple_roller_load != 0) {
            double ripple = cd_load_ripple_torque(&s->extra, theta, m->order, tau_out);
            dyn = dyn + ripple;
            p_stored = p_stored + ripple;
        }
        if (shaft_ripple(&s->extra)) {   /* zero-mean at a held load: stored */
            double ripple = cd_shaft_order_ripple_torque(&s->extra, theta, m->ratio_out,
                                                         tau_out);
            dyn = dyn + ripple;
            p_stored = p_stored + ripple;
        }
        tau_in += dyn;
        if (s->extra.run_in_change != 0)   /* the gear's load-dependent losses alone */
            tau_in += cd_run_in_torque(&s->extra, distance, cd_load_loss_torque(
                s->out[O_PL1] + s->out[O_PL2] + s->out[O_PL3] + s->out[O_PL5] + s->out[O_PL6],
                w_in));
        if (s->extra.thermal_loss_per_10K != 0)   /* at T_oil; the losses at T_oil_start */
            tau_in += cd_thermal_per_10K_torque(&s->extra, s->out[O_T_OIL], loss_in);
        p_stored = p_stored * w_in;
    }
    s->out[O_TAU_IN] = tau_in;
    /* the support takes what the shafts do not: the gear's reaction and the drag of bearings,
     * seals and grease (they act between the shafts and the housing), so that
     * tau_in + tau_out + tau_housing = input_inertia * alpha (0 without it) */
    s->out[O_TAU_HOUSING] = -(tau_in - inertia + tau_out);
    s->out[O_P_EXTRA] = (tau_in - tau_in_gear) * w_in;
    s->out[O_P_STORED] = p_stored;
    s->out[O_P_LOSS] = tau_in * w_in + tau_out * s->out[O_W_OUT] - p_stored;
    if (steady || dynamic || transition) {
        double pa = tau_in * w_in, pb = tau_out * s->out[O_W_OUT];
        p_in = pa > pb ? pa : pb;
        p_out = -(pa < pb ? pa : pb);
        r.eta = (p_in > 0 && p_out > 0 && !r.locked) ? p_out / p_in : 0.0;
    }
    s->out[O_ETA] = r.eta;
    s->out[O_ETA0] = r.eta0;
    s->locked = r.locked;
    s->out[O_TORQUE_OUT] = -tau_out;
    output_inertia(s, mode, tau_ext, J_r, tau_in_gear, commit, T);
}

/* Every output a finite number (an extreme input, e.g. tau_out = -1e308, overflows the
 * products of the map's torques and speeds). */
static int outputs_finite(const CDState *s)
{
    int i;
    for (i = 0; i < N_OUT_ALL; i++)
        if (!isfinite(s->out[i])) return 0;
    return 1;
}

static fmi2Status nonfinite(Instance *c, const char *fn)
{
    logmsg(c, fmi2Error, "%s: w_in = %g rad/s, tau_out = %g N.m, alpha_in = %g rad/s2 give "
           "outputs that are not finite numbers (inputs far beyond any drive): refused, the "
           "state is that before the call", fn, c->s.w_in, c->s.tau_out, c->s.alpha_in);
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component comp)
{
    CHECK_INSTANCE(fmi2ExitInitializationMode);
    if (c->s.phase != PH_INIT) return not_in_phase(c, "fmi2ExitInitializationMode");
    {
        CDState before = c->s;
        c->s.mode_eff = resolve_mode(&c->s);
        c->s.phase = PH_STEP;
        c->s.has_key = 0;
        c->s.T = c->s.thermal[0];   /* the heat balance starts here */
        evaluate(c, c->s.t_start, 0.0, 1);
        if (!outputs_finite(&c->s)) {
            c->s = before;
            return nonfinite(c, "fmi2ExitInitializationMode");
        }
    }
    return fmi2OK;
}

/* -- get and set ---------------------------------------------------------------------------- */
static int const_index_real(unsigned int vr)
{
    int i;
    for (i = 0; i < CD_N_CONST_REAL; i++) if (CD_CONST_REAL[i].vr == vr) return i;
    return -1;
}

/* Initialization Mode: the outputs follow the inputs and parameters set so far (f_init). */
static int refresh(Instance *c)
{
    if (c->s.phase == PH_INIT || c->s.phase == PH_INSTANTIATED) {
        evaluate(c, c->s.t_start, 0.0, 0);
        return outputs_finite(&c->s);
    }
    return 1;
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[],
                                   size_t nvr, fmi2Real value[])
{
    size_t i;
    int refreshed = 0;
    CHECK_INSTANCE(fmi2GetReal);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        unsigned int r = vr[i];
        int k;
        if (r == VR_W_IN) value[i] = c->s.w_in;
        else if (r == VR_TAU_OUT) value[i] = c->s.tau_out;
        else if (r == VR_ALPHA_IN) value[i] = c->s.alpha_in;
        else if (r == VR_J_OUT) value[i] = c->s.J_out;
        else if (r == VR_ALPHA_REF) value[i] = c->s.alpha_ref;
        else if (r == VR_T_OIL_IN) value[i] = c->s.T_oil_in;
        else if (r >= VR_THERMAL0 && r < VR_THERMAL0 + CD_N_THERMAL)
            value[i] = c->s.thermal[r - VR_THERMAL0];
        else if ((r >= VR_OUT0 && r < VR_OUT0 + N_OUT)
                 || (r >= VR_PL_MESH && r <= VR_Q_AMBIENT)) {
            if (!refreshed) {
                if (!refresh(c)) return nonfinite(c, "fmi2GetReal");
                refreshed = 1;
            }
            value[i] = c->s.out[r >= VR_PL_MESH ? O_PL_MESH + (int)(r - VR_PL_MESH)
                                                : (int)(r - VR_OUT0)];
        } else if ((k = extra_index(r)) >= 0)
            value[i] = *extra_field(&c->s.extra, k);
        else if ((k = const_index_real(r)) >= 0) value[i] = CD_CONST_REAL[k].value;
        else return bad_vr(c, "fmi2GetReal", r);
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[],
                                      size_t nvr, fmi2Integer value[])
{
    size_t i;
    int k;
    CHECK_INSTANCE(fmi2GetInteger);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_MODE_NUMBER) { value[i] = c->s.mode_number; continue; }
        for (k = 0; k < CD_N_CONST_INTEGER; k++)
            if (CD_CONST_INTEGER[k].vr == vr[i]) break;
        if (k == CD_N_CONST_INTEGER) return bad_vr(c, "fmi2GetInteger", vr[i]);
        value[i] = CD_CONST_INTEGER[k].value;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[],
                                      size_t nvr, fmi2Boolean value[])
{
    size_t i;
    CHECK_INSTANCE(fmi2GetBoolean);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_USE_T_OIL) {
            value[i] = c->s.use_T_oil_input ? fmi2True : fmi2False;
            continue;
        }
        if (vr[i] != VR_LOCKED) return bad_vr(c, "fmi2GetBoolean", vr[i]);
        if (!refresh(c)) return nonfinite(c, "fmi2GetBoolean");
        value[i] = c->s.locked ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

static const char *const MODE_STRINGS[CD_N_MODES] = {"12", "21", "1S", "S1", "2S", "S2"};

FMI2_Export fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[],
                                     size_t nvr, fmi2String value[])
{
    size_t i;
    int k;
    CHECK_INSTANCE(fmi2GetString);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_MODE) { value[i] = MODE_STRINGS[c->s.mode]; continue; }
        for (k = 0; k < CD_N_CONST_STRING; k++)
            if (CD_CONST_STRING[k].vr == vr[i]) break;
        if (k == CD_N_CONST_STRING) return bad_vr(c, "fmi2GetString", vr[i]);
        value[i] = CD_CONST_STRING[k].value;
    }
    return fmi2OK;
}

static int parameters_settable(Instance *c)
{
    return c->s.phase == PH_INSTANTIATED || c->s.phase == PH_INIT;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[],
                                   size_t nvr, const fmi2Real value[])
{
    size_t i;
    fmi2Status status = fmi2OK;
    CHECK_INSTANCE(fmi2SetReal);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    if (c->s.phase == PH_TERMINATED) return not_in_phase(c, "fmi2SetReal");
    for (i = 0; i < nvr; i++) {
        unsigned int r = vr[i];
        double v = value[i];
        if (r == VR_W_IN || r == VR_TAU_OUT || r == VR_ALPHA_IN) {
            const char *name = r == VR_W_IN ? "w_in" : r == VR_TAU_OUT ? "tau_out" : "alpha_in";
            double *dst = r == VR_W_IN ? &c->s.w_in : r == VR_TAU_OUT ? &c->s.tau_out
                        : &c->s.alpha_in;
            if (!isfinite(v)) {
                logmsg(c, fmi2Error, "%s = %g: input must be a finite number (kept %g)", name,
                       v, *dst);
                status = fmi2Error;
                continue;
            }
            *dst = v;
        } else if (r == VR_T_OIL_IN) {
            /* its range is checked where it is used (use_T_oil_input) */
            if (!isfinite(v)) {
                logmsg(c, fmi2Error, "T_oil_in = %g: input must be a finite number (kept %g)",
                       v, c->s.T_oil_in);
                status = fmi2Error;
            } else {
                c->s.T_oil_in = v;
            }
        } else if (r >= VR_THERMAL0 && r < VR_THERMAL0 + CD_N_THERMAL) {
            int k = (int)(r - VR_THERMAL0);
            const char *why = thermal_problem(k, v);
            if (!parameters_settable(c)) {
                logmsg(c, fmi2Error, "%s is a fixed parameter: set it before "
                       "fmi2ExitInitializationMode", THERMAL_NAMES[k]);
                status = fmi2Error;
            } else if (why) {
                logmsg(c, fmi2Error, "invalid parameter: %s = %g %s (kept %g)", THERMAL_NAMES[k],
                       v, why, c->s.thermal[k]);
                status = fmi2Error;
            } else {
                c->s.thermal[k] = v;
            }
        } else if (r == VR_J_OUT || r == VR_ALPHA_REF) {
            const char *name = r == VR_J_OUT ? "J_out" : "alpha_ref";
            double *dst = r == VR_J_OUT ? &c->s.J_out : &c->s.alpha_ref;
            /* CycloidDrive._setup: J_out >= 0, alpha_ref > 0 */
            int ok = isfinite(v) && (r == VR_J_OUT ? v >= 0 : v > 0);
            if (!parameters_settable(c)) {
                logmsg(c, fmi2Error, "%s is a fixed parameter: set it before "
                       "fmi2ExitInitializationMode", name);
                status = fmi2Error;
            } else if (!ok) {
                logmsg(c, fmi2Error, "invalid parameter: %s = %g %s (kept %g)", name, v,
                       r == VR_J_OUT ? "must not be negative" : "must be positive", *dst);
                status = fmi2Error;
            } else {
                *dst = v;
            }
        } else if (extra_index(r) >= 0) {
            int k = extra_index(r);
            const char *why = extra_problem(k, v);
            if (!parameters_settable(c)) {
                logmsg(c, fmi2Error, "%s is a fixed parameter: set it before "
                       "fmi2ExitInitializationMode", EXTRA_NAMES[k]);
                status = fmi2Error;
            } else if (why) {
                logmsg(c, fmi2Error, "invalid parameter: %s = %g %s (kept %g)", EXTRA_NAMES[k],
                       v, why, *extra_field(&c->s.extra, k));
                status = fmi2Error;
            } else {
                *extra_field(&c->s.extra, k) = v;
            }
        } else if ((r >= VR_OUT0 && r < VR_OUT0 + N_OUT)
                   || (r >= VR_PL_MESH && r <= VR_Q_AMBIENT)) {
            logmsg(c, fmi2Error, "fmi2SetReal: value reference %u is an output", r);
            status = fmi2Error;
        } else if (const_index_real(r) >= 0) {
            logmsg(c, fmi2Error, "fmi2SetReal: value reference %u is a constant of the design "
                   "this FMU was built for (rebuild with another design file to change it)", r);
            status = fmi2Error;
        } else {
            return bad_vr(c, "fmi2SetReal", r);
        }
    }
    return status;
}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[],
                                      size_t nvr, const fmi2Integer value[])
{
    size_t i;
    fmi2Status status = fmi2OK;
    CHECK_INSTANCE(fmi2SetInteger);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_MODE_NUMBER) {
            logmsg(c, fmi2Error, "fmi2SetInteger: value reference %u is not a settable "
                   "Integer (mode_number is %u)", vr[i], VR_MODE_NUMBER);
            status = fmi2Error;
        } else if (!parameters_settable(c)) {
            logmsg(c, fmi2Error, "mode_number is a fixed parameter: set it before "
                   "fmi2ExitInitializationMode");
            status = fmi2Error;
        } else if (value[i] < 0 || value[i] > CD_N_MODES) {
            logmsg(c, fmi2Error, "invalid parameter: mode_number = %d must be 0 (use mode) or "
                   "1..6 (12, 21, 1S, S1, 2S, S2)", (int)value[i]);
            status = fmi2Error;
        } else {
            c->s.mode_number = value[i];
        }
    }
    return status;
}

FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[],
                                      size_t nvr, const fmi2Boolean value[])
{
    size_t i;
    fmi2Status status = fmi2OK;
    CHECK_INSTANCE(fmi2SetBoolean);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] != VR_USE_T_OIL) {
            logmsg(c, fmi2Error, "fmi2SetBoolean: value reference %u is not settable (locked is "
                   "an output; use_T_oil_input is %u)", vr[i], VR_USE_T_OIL);
            status = fmi2Error;
        } else if (!parameters_settable(c)) {
            logmsg(c, fmi2Error, "use_T_oil_input is a fixed parameter: set it before "
                   "fmi2ExitInitializationMode");
            status = fmi2Error;
        } else {
            c->s.use_T_oil_input = value[i] != fmi2False;
        }
    }
    return status;
}

FMI2_Export fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[],
                                     size_t nvr, const fmi2String value[])
{
    size_t i;
    fmi2Status status = fmi2OK;
    CHECK_INSTANCE(fmi2SetString);
    if (nvr && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        int m;
        char q[64];
        if (vr[i] != VR_MODE) {
            logmsg(c, fmi2Error, "fmi2SetString: value reference %u is not a settable String "
                   "(mode is %u)", vr[i], VR_MODE);
            status = fmi2Error;
            continue;
        }
        if (!parameters_settable(c)) {
            logmsg(c, fmi2Error, "mode is a fixed parameter: set it before "
                   "fmi2ExitInitializationMode");
            status = fmi2Error;
            continue;
        }
        m = cd_mode_index(value[i]);
        if (m < 0) {
            quote(value[i], q, sizeof q);
            logmsg(c, fmi2Error, "invalid parameter: mode = %s must be one of 12, 21, 1S, S1, "
                   "2S, S2 (driving shaft, driven shaft; 1 ring, 2 disc, S eccentric)", q);
            status = fmi2Error;
            continue;
        }
        c->s.mode = m;
    }
    return status;
}

/* -- FMU state ------------------------------------------------------------------------------ */
static int flag(int v) { return v == 0 || v == 1; }

/* A state from a host's bytes: every field is checked as fmi2SetReal and the step would check
 * it, so a corrupted state is refused instead of giving NaN outputs with fmi2OK. NULL if
 * valid, else the first field that is not. */
static const char *state_problem(const CDState *s)
{
    int i;
    if (s->magic != STATE_MAGIC || s->version != STATE_VERSION) return "magic/version";
    if (s->phase < PH_INSTANTIATED || s->phase > PH_TERMINATED) return "phase";
    if (s->mode < 0 || s->mode >= CD_N_MODES) return "mode";
    if (s->mode_eff < 0 || s->mode_eff >= CD_N_MODES) return "mode_eff";
    if (s->mode_number < 0 || s->mode_number > CD_N_MODES) return "mode_number";
    for (i = 0; i < CD_N_EXTRA; i++)
        if (extra_problem(i, *extra_field((CDExtra *)&s->extra, i))) return EXTRA_NAMES[i];
    if (!isfinite(s->w_in)) return "w_in";
    if (!isfinite(s->tau_out)) return "tau_out";
    if (!isfinite(s->alpha_in)) return "alpha_in";
    if (!(isfinite(s->J_out) && s->J_out >= 0)) return "J_out";
    if (!(isfinite(s->alpha_ref) && s->alpha_ref > 0)) return "alpha_ref";
    if (!isfinite(s->t_start)) return "t_start";
    if (!isfinite(s->theta)) return "theta";
    if (!(isfinite(s->distance) && s->distance >= 0)) return "distance";
    if (!isfinite(s->w_last)) return "w_last";
    if (!isfinite(s->T_oil_in)) return "T_oil_in";
    if (!(s->T > T_OIL_MIN && s->T < T_OIL_MAX)) return "T";
    for (i = 0; i < CD_N_THERMAL; i++)
        if (thermal_problem(i, s->thermal[i])) return THERMAL_NAMES[i];
    if (!flag(s->use_T_oil_input)) return "use_T_oil_input";
    for (i = 0; i < N_OUT_ALL; i++)
        if (!isfinite(s->out[i])) return "outputs";
    if (!flag(s->locked) || !flag(s->has_w_last) || !flag(s->warned_range) || !flag(s->has_key))
        return "flags";
    if (s->has_key && !(isfinite(s->key_w) && isfinite(s->key_tau) && isfinite(s->key_J_acc)
                        && isfinite(s->key_J_dec) && s->key_J_acc > 0 && s->key_J_dec > 0))
        return "J_load secants";
    return NULL;
}

FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate)
{
    const CDState *s = (const CDState *)FMUstate;
    const char *why;
    CHECK_INSTANCE(fmi2SetFMUstate);
    if (s == NULL || (why = state_problem(s)) != NULL) {
        logmsg(c, fmi2Error, "fmi2SetFMUstate: not a state of this FMU (%s)",
               s ? why : "NULL");
        return fmi2Error;
    }
    c->s = *s;
    return fmi2OK;
}

/* serialised: the GUID (FRONT_GUID_BYTES, fmi2_front.h), then CDState */
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp,
                                               const fmi2Byte serializedState[], size_t size,
                                               fmi2FMUstate *FMUstate)
{
    char guid[FRONT_GUID_BYTES];
    const char *why;
    CDState s, *dst;
    CHECK_INSTANCE(fmi2DeSerializeFMUstate);
    if (serializedState == NULL || FMUstate == NULL || size != FRONT_GUID_BYTES + sizeof(CDState)) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: %lu bytes, expected %lu",
               (unsigned long)size, (unsigned long)(FRONT_GUID_BYTES + sizeof(CDState)));
        return fmi2Error;
    }
    guid_bytes(guid);
    memcpy(&s, serializedState + FRONT_GUID_BYTES, sizeof s);
    if (memcmp(serializedState, guid, FRONT_GUID_BYTES) != 0) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: not a state of this FMU (GUID %s)",
               CD_GUID);
        return fmi2Error;
    }
    if ((why = state_problem(&s)) != NULL) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: corrupted state (field %s invalid)",
               why);
        return fmi2Error;
    }
    dst = (CDState *)(*FMUstate ? *FMUstate : mem_alloc(c, sizeof *dst));
    if (dst == NULL) {
        logmsg(c, fmi2Error, "fmi2DeSerializeFMUstate: out of memory");
        return fmi2Error;
    }
    *dst = s;
    *FMUstate = dst;
    return fmi2OK;
}

/* -- co-simulation -------------------------------------------------------------------------- */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real currentCommunicationPoint,
                                  fmi2Real communicationStepSize,
                                  fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    CHECK_INSTANCE(fmi2DoStep);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c->s.phase != PH_STEP) return not_in_phase(c, "fmi2DoStep");
    if (step_arguments(c, currentCommunicationPoint, communicationStepSize) != fmi2OK)
        return fmi2Error;
    {
        CDState before = c->s;
        evaluate(c, currentCommunicationPoint + communicationStepSize, communicationStepSize, 1);
        if (!outputs_finite(&c->s)) {
            c->s = before;
            return nonfinite(c, "fmi2DoStep");
        }
        /* the step that first left the map (eta0 held at its edge) says so in its status */
        return c->s.warned_range && !before.warned_range ? fmi2Warning : fmi2OK;
    }
}
