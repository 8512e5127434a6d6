/* Native bench components (motor, brake, transducers): the interface between the shared FMI 2.0
 * front (rig_fmi2.c) and one component's physics (rig_motor.c, rig_brake.c, rig_transducer.c).
 *
 * A component's variables are those of its Python slave (cyclo_fmu/slaves), read from the
 * slave's model description by cyclo_fmu/native/rig_build.py, which generates rig_vars.h: the
 * slot of every variable in the state's arrays (R_<name>, I_<name>, B_<name>, S_<name>), the
 * variable table of the front, the GUID. Written for cyclo-fmu (MIT license). */
#ifndef RIG_MODEL_H
#define RIG_MODEL_H

#include <stddef.h>

#include "rig_vars.h"

#define RIG_STRLEN 1024          /* bytes of a String parameter, terminator included */
#define RIG_MAX_SCHEDULE 256     /* setpoints of a parsed schedule */
#define RIG_NX 8                 /* doubles of a component's own dynamic state */

enum { RIG_PH_INSTANTIATED = 1, RIG_PH_INIT, RIG_PH_STEP, RIG_PH_TERMINATED };
enum { RIG_PARAMETER, RIG_INPUT, RIG_OUTPUT, RIG_LOCAL };

typedef struct {
    unsigned int vr;
    char type;            /* 'R', 'I', 'B', 'S' */
    int slot;             /* index in the state's array of that type */
    int causality;
    int has_min, has_max;
    double min, max;
    double start;         /* Real, Integer, Boolean */
    const char *start_string;
    const char *name;
} RigVar;

/* Plain data (no pointers): what fmi2GetFMUstate copies and fmi2SerializeFMUstate writes. */
typedef struct {
    unsigned int magic, version;
    int phase;
    double t_start;
    double r[RIG_NR];
    int i[RIG_NI];
    int b[RIG_NB];
    char s[RIG_NS][RIG_STRLEN];
    double x[RIG_NX];                      /* the component's dynamic state */
    int n_schedule;                        /* -1: none */
    double schedule[RIG_MAX_SCHEDULE][2];  /* (time s, value) */
} RigState;

/* The component: 0 = fine, else a message in msg (no '%' needed: the front escapes it). */
int rig_setup(RigState *s, char *msg, size_t n);     /* validate parameters, prepare */
int rig_init(RigState *s, char *msg, size_t n);      /* outputs and state at the start */
int rig_step(RigState *s, double t, double h, char *msg, size_t n);
int rig_state_valid(const RigState *s);              /* a restored state is usable */

/* Shared by the components (rig_common.c), each the C twin of a model_core.rig function. */
double rig_floordiv(double a, double b);             /* Python's float // */
double rig_series_value(double t, double first, double last, int count, double hold,
                        int repeat);                 /* model_core.rig.series_value */
double rig_schedule_value(const RigState *s, double t);   /* model_core.rig.schedule_value */
/* The schedule of String parameter text, or of the numbered parameters (count, times[],
 * values[]), not both (SlaveBase.schedule_from_parameters); n_schedule = -1 without one. */
int rig_load_schedule(RigState *s, const char *text_name, const char *text, int count,
                      const double *times, const double *values, char *msg, size_t n);
double rig_normal_sample(unsigned long long seed, unsigned long long k);  /* rig.normal_samples */
int rig_finite(double v);

#endif
