/* Cycloid drive, native FMU: the loss map of one design and the step arithmetic.
 *
 * Pure C99, no FMI types: the same arithmetic, in the same order, as the Python side
 * (model_core.lossmap.ModeMap.solve, model_core.design.ExtraPhysics.steady_torque and
 * dynamic_torque, cyclo_fmu.slaves.cycloid_drive.CycloidDrive._update), so that the two FMUs
 * agree to rounding. Compile with -ffp-contract=off: a fused multiply-add would change the
 * last bits of the bilinear interpolation.
 *
 * cyclo-fmu, MIT license.
 */
#ifndef CD_MODEL_H
#define CD_MODEL_H

#define CD_N_MODES 6
#define CD_N_LOSSES 9          /* PL1, PL2, PL3, PL5, PL6, PL_support, PL_seal, PL_churn,
                                  PL_mesh */
#define CD_N_GEAR 5            /* the gear's own partial losses PL1..PL6 */
#define CD_N_COLS (2 + CD_N_GEAR)     /* eta0, the shares of the gear's partial losses PL1..PL6,
                                         then the share of the calibrated mesh loss PL_mesh */
#define CD_N_IDLE 6            /* drag row: PL_support, PL_seal, PL_churn over |w_in| (N*m),
                                  then the torque spent on the drag at shafts 1, 2, S (N*m) */

/* One operating mode (driving shaft a, driven shaft b, held shaft h; 0 = ring 1, 1 = disc 2,
 * 2 = eccentric S). */
typedef struct {
    const char *name;          /* "12", "21", "1S", "S1", "2S", "S2" */
    double ratio[3];           /* shaft speeds per unit driving speed (1, 2, S) */
    int a, b, h;
    int wdir[2];               /* [forward]: +1 if the known torque gives e = eta0, else -1 */
    const double *table[2];    /* [forward]: n_speed x n_torque x CD_N_COLS, row-major */
    const double *idle;        /* n_speed x CD_N_IDLE: the drag at the shafts, w_in > 0 */
    double ratio_out;          /* driven speed per unit driving speed */
    double order;              /* roller-pass order: ripple cycles per driving turn */
} CDMode;

/* The loss map of one design: all six modes, both power-flow directions. */
typedef struct {
    int n_torque, n_speed;
    const double *lt;          /* ln |tau| grid (the gear's torque at the driven shaft), N*m */
    const double *lw;          /* ln |w_in| grid, rad/s */
    double i0;                 /* basic ratio (z1 - 1)/z1 */
    double w_low;              /* rad/s, the lowest speed of the grid (ModeMap._w_low) */
    CDMode modes[CD_N_MODES];
} CDMap;

/* Physics beyond the paper (design [extra]), run-time parameters of the FMU. */
typedef struct {
    double drag_torque, stribeck_torque, stribeck_speed, input_inertia;
    double ripple_1x, ripple_1x_phase, ripple_roller, ripple_roller_phase;
    double thermal_loss_change, thermal_tau, drag_exponent;
    double stribeck_exponent;  /* delta of exp(-(|w|/w_s)^delta): 1 Tustin .. 2 Gaussian */
    double run_in_change, run_in_distance;   /* run-in: c exp(-distance/s0) T_load (PL1..PL6) */
    double ripple_1x_load, ripple_1x_load_phase, ripple_roller_load, ripple_roller_load_phase;
    /* the warm-up per 10 K: c (T_oil - T_ref)/10 K loss_in */
    double thermal_loss_per_10K, thermal_T_ref;
    /* the mesh ripple at 2x the driving shaft, 1x and 2x the driven shaft
     * (ExtraPhysics.shaft_order_ripple_torque): amplitude, phase, load-scaled amplitude at
     * 10 N*m of |tau_out|, its phase */
    double ripple_2x, ripple_2x_phase, ripple_2x_load, ripple_2x_load_phase;
    double ripple_out_1x, ripple_out_1x_phase, ripple_out_1x_load, ripple_out_1x_load_phase;
    double ripple_out_2x, ripple_out_2x_phase, ripple_out_2x_load, ripple_out_2x_load_phase;
    /* the standstill friction's sign through a speed reversal, tanh(w/w_r) (0: sgn(w)),
     * rad/s (model_core.friction.reversal_sign) */
    double stribeck_transition;
    /* the warm-up's temperature law: its temperature scale theta, K (0: the linear law;
     * model_core.thermal.loss_temperature_law) */
    double thermal_T_scale;
    /* the whole loss through standstill: its transition width w_c, rad/s (0: the losses at
     * full value; model_core.friction.loss_transition) */
    double loss_transition;
} CDExtra;

#define CD_N_EXTRA 35

/* A discovered loss term (design [[extra.discovered]], model_core.discovered): the torque
 * coefficient * sgn(w) (|w|/300 rad/s)^speed_exponent (|tau_out|/10 N*m)^load_exponent. */
#define CD_MAX_DISCOVERED 4    /* model_core.discovered.MAX_TERMS */
typedef struct { double coefficient, speed_exponent, load_exponent; } CDTerm;

typedef struct {
    double speeds[3], torques[3], losses[CD_N_LOSSES];
    double eta, eta0;
    int locked, forward;
    int out_of_range;          /* 1 if the look-up was clamped at the map's edge */
} CDSolution;

/* The loss maps over the grease temperature (model_core.lossmap.ThermalMap): one CDMap per
 * node, at temperatures T[0] < T[1] < ... (K); n = 1 where the losses do not depend on it. */
typedef struct {
    int n;
    const double *T;
    const CDMap *maps;
} CDThermalMap;

/* ThermalMap.solve: the steady state at grease temperature T (K), linear in T between the two
 * nodes around it (blend_solutions), clamped at the outer nodes. */
void cd_solve_thermal(const CDThermalMap *tm, int mode, double w_in, double tau_out, double T,
                      CDSolution *out);

/* model_core.thermal.housing_step: the temperature after a step dt of C dT/dt = P - (T -
 * T_amb)/R with P held (exact exponential update). */
double cd_housing_step(double T, double P, double dt, double T_amb, double C, double R);

/* ModeMap.solve: steady state at driving speed w_in (rad/s) and load torque tau_out (N*m). */
void cd_solve(const CDMap *map, int mode, double w_in, double tau_out, CDSolution *out);

/* ExtraPhysics.steady_torque: drag and Stribeck torque at driving speed w (N*m). */
double cd_steady_torque(const CDExtra *x, double w);

/* ExtraPhysics.thermal_per_10K_torque: the loss change per 10 K of the grease temperature T
 * (K) from thermal_T_ref (N*m), linear or (thermal_T_scale > 0) the exponential law. */
double cd_thermal_per_10K_torque(const CDExtra *x, double T, double loss_in);

/* ExtraPhysics.loss_transition_share: the share tanh(|w|/w_c) of the model's losses built up
 * at driving speed w (rad/s); 1 at loss_transition 0 (model_core.friction.loss_transition). */
double cd_loss_transition(const CDExtra *x, double w);

/* ExtraPhysics.dynamic_torque: inertia, ripple and warm-up torque (N*m). */
double cd_dynamic_torque(const CDExtra *x, double alpha, double theta, double order,
                         double elapsed, double loss_in);

/* ExtraPhysics.run_in_torque: run-in torque after the driving shaft travelled distance (rad)
 * at the gear's load-dependent loss torque load_loss_in (N*m, cd_load_loss_torque). */
double cd_run_in_torque(const CDExtra *x, double distance, double load_loss_in);

/* lossmap.load_loss_torque: the gear's load-dependent loss torque at the driving shaft (N*m),
 * the power of PL1..PL6 P_load (W) over the driving speed w_in (rad/s); 0 at a standstill. */
double cd_load_loss_torque(double P_load, double w_in);

/* ExtraPhysics.load_ripple_torque: the ripple whose amplitude grows with |tau_out| (N*m). */
double cd_load_ripple_torque(const CDExtra *x, double theta, double order, double tau_out);

/* ExtraPhysics.shaft_order_ripple_torque: the ripple at 2x the driving shaft and at 1x and 2x
 * the driven shaft (angle ratio_out * theta), each a + b |tau_out|/10 N*m (N*m). */
double cd_shaft_order_ripple_torque(const CDExtra *x, double theta, double ratio_out,
                                    double tau_out);

/* model_core.discovered.discovered_torque: the sum of n terms at driving speed w (rad/s) and
 * load torque tau_out (N*m), N*m. */
double cd_discovered_torque(const CDTerm *terms, int n, double w, double tau_out);

/* Index of a mode string ("S1", " s1 " ...) or -1. */
int cd_mode_index(const char *mode);

/* The design this FMU was built for (generated at build time: cd_map_data.c): its loss map,
 * the defaults of the extra physics, the design values shown as constants, the GUID. */
extern const CDMap CD_MAP;              /* the map at the operating temperature */
extern const CDThermalMap CD_THERMAL;     /* all nodes over the grease temperature */
extern const CDExtra CD_DEFAULT_EXTRA;
extern const CDTerm CD_DISCOVERED[CD_MAX_DISCOVERED];   /* built in, as the map */
extern const int CD_N_DISCOVERED;
extern const char CD_GUID[];
/* the heat balance's parameters' defaults: T_oil_start, ambient_temperature (K),
 * housing_heat_capacity (J/K), housing_heat_transfer (W/(m2 K)), housing_area (m2) */
#define CD_N_THERMAL 5
extern const double CD_DEFAULT_THERMAL[CD_N_THERMAL];
extern const double CD_MAP_TORQUE_MAX;   /* N*m, largest |tau_out| of the map */
extern const double CD_MAP_SPEED_MAX;    /* rad/s, largest |w_in| of the map */

typedef struct { unsigned int vr; double value; } CDConstReal;
typedef struct { unsigned int vr; int value; } CDConstInteger;
typedef struct { unsigned int vr; const char *value; } CDConstString;
extern const CDConstReal CD_CONST_REAL[];
extern const int CD_N_CONST_REAL;
extern const CDConstInteger CD_CONST_INTEGER[];
extern const int CD_N_CONST_INTEGER;
extern const CDConstString CD_CONST_STRING[];
extern const int CD_N_CONST_STRING;

#endif
