/* A bench component without physics for benchmarks/bench_bench.py: the shared native front
 * (rig_fmi2.c) with a step that does nothing, so that stepping seven of these measures the
 * master and the FMI calls alone (the floor under the native bench). */
#include "rig_model.h"

int rig_setup(RigState *s, char *msg, size_t n) { (void)s; (void)msg; (void)n; return 0; }
int rig_init(RigState *s, char *msg, size_t n) { (void)s; (void)msg; (void)n; return 0; }
int rig_step(RigState *s, double t, double h, char *msg, size_t n)
{
    (void)s; (void)t; (void)h; (void)msg; (void)n;
    return 0;
}
int rig_state_valid(const RigState *s) { (void)s; return 1; }
