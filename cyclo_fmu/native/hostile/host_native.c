/* A hostile host for CycloidDriveNative, compiled with the FMU's sources under AddressSanitizer
 * and UndefinedBehaviorSanitizer (cyclo_fmu/native/sanitize.py): NULL arguments everywhere,
 * printf directives in strings, inputs at and beyond every edge of the map, corrupted
 * serialised states, an allocator without a matching free, and threads that create, step and
 * free instances at once. Any memory error or undefined behaviour aborts (the sanitizers);
 * a call that answers fmi2OK with a non-finite output is counted and fails the run.
 *
 * usage: host_native [iterations [threads]]   (exit 0: clean; "threads": the 8 threads only,
 *        for the ThreadSanitizer build)
 * cyclo-fmu, MIT license. */
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "cd_model.h"

static int problems = 0;
static int iterations = 200;

#define CHECK(cond, ...) do { if (!(cond)) { problems++; fprintf(stderr, "PROBLEM: " __VA_ARGS__); \
    fputc('\n', stderr); } } while (0)

/* a host logger that formats the message, as FMI Library does: a directive left in it would
 * read arguments that are not there (ASan/UBSan would see it) */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status st, fmi2String cat,
                   fmi2String msg, ...)
{
    char buf[4096];
    va_list ap;
    (void)env; (void)name; (void)st; (void)cat;
    va_start(ap, msg);
    vsnprintf(buf, sizeof buf, msg, ap);
    va_end(ap);
    if (getenv("HOSTILE_VERBOSE")) fprintf(stderr, "  log: %s\n", buf);
}

static void *alloc(size_t n, size_t k) { return calloc(n, k); }

static const fmi2CallbackFunctions CB = {logger, alloc, free, NULL, NULL};
static const fmi2CallbackFunctions CB_NO_FREE = {logger, alloc, NULL, NULL, NULL};
static const fmi2CallbackFunctions CB_NONE = {NULL, NULL, NULL, NULL, NULL};

enum { VR_W_IN = 0, VR_TAU_OUT = 1, VR_ALPHA_IN = 2 };
static fmi2ValueReference OUT_VR[20];

static fmi2Component started(const char *mode, double J_out)
{
    fmi2Component c = fmi2Instantiate("h", fmi2CoSimulation, CD_GUID, "file:///tmp", &CB,
                                      fmi2False, fmi2True);
    const fmi2ValueReference vr_mode = 0, vr_J = 50;
    fmi2String m[1];
    m[0] = mode;
    if (c == NULL) return NULL;
    fmi2SetupExperiment(c, fmi2False, 0, 0.0, fmi2False, 0);
    fmi2EnterInitializationMode(c);
    fmi2SetString(c, &vr_mode, 1, m);
    fmi2SetReal(c, &vr_J, 1, &J_out);
    fmi2ExitInitializationMode(c);
    return c;
}

/* a step: fmi2OK must come with finite outputs */
static fmi2Status step(fmi2Component c, double t, double w, double tau, double alpha)
{
    const fmi2ValueReference in[3] = {VR_W_IN, VR_TAU_OUT, VR_ALPHA_IN};
    double v[3], out[20];
    fmi2Status s;
    int i;
    v[0] = w; v[1] = tau; v[2] = alpha;
    fmi2SetReal(c, in, 3, v);
    s = fmi2DoStep(c, t, 1e-3, fmi2True);
    if (fmi2GetReal(c, OUT_VR, 20, out) == fmi2OK && s <= fmi2Warning)
        for (i = 0; i < 20; i++)
            CHECK(isfinite(out[i]), "step w=%g tau=%g alpha=%g: output %d = %g with status %d",
                  w, tau, alpha, i, out[i], (int)s);
    return s;
}

static void nulls(void)
{
    fmi2Component c;
    fmi2FMUstate st = NULL;
    fmi2String cats[2] = {"logAll", NULL};
    fmi2String bad[1] = {NULL};
    const fmi2ValueReference vr0 = 0;
    double x = 0;
    size_t n = 0;
    c = fmi2Instantiate(NULL, fmi2CoSimulation, CD_GUID, NULL, &CB, 0, 0);   /* name "" */
    if (c) fmi2FreeInstance(c);
    CHECK(fmi2Instantiate("x", fmi2CoSimulation, NULL, NULL, &CB, 0, 0) == NULL, "NULL GUID");
    CHECK(fmi2Instantiate("x", fmi2CoSimulation, "%s%s%n", NULL, &CB, 0, 0) == NULL, "GUID");
    CHECK(fmi2Instantiate("x", fmi2ModelExchange, CD_GUID, NULL, &CB, 0, 0) == NULL, "ME");
    CHECK(fmi2Instantiate("x", fmi2CoSimulation, CD_GUID, NULL, &CB_NO_FREE, 0, 0) == NULL,
          "allocateMemory without freeMemory accepted");
    c = fmi2Instantiate("%s%n", fmi2CoSimulation, CD_GUID, NULL, NULL, 0, 1);   /* no callbacks */
    if (c) fmi2FreeInstance(c);
    c = fmi2Instantiate("%s%n", fmi2CoSimulation, CD_GUID, NULL, &CB_NONE, 0, 1);
    if (c) fmi2FreeInstance(c);
    /* NULL component everywhere */
    CHECK(fmi2SetDebugLogging(NULL, 1, 0, NULL) == fmi2Error, "NULL c");
    CHECK(fmi2SetupExperiment(NULL, 0, 0, 0, 0, 0) == fmi2Error, "NULL c");
    CHECK(fmi2EnterInitializationMode(NULL) == fmi2Error, "NULL c");
    CHECK(fmi2ExitInitializationMode(NULL) == fmi2Error, "NULL c");
    CHECK(fmi2Terminate(NULL) == fmi2Error, "NULL c");
    CHECK(fmi2Reset(NULL) == fmi2Error, "NULL c");
    CHECK(fmi2GetReal(NULL, &vr0, 1, &x) == fmi2Error, "NULL c");
    CHECK(fmi2SetReal(NULL, &vr0, 1, &x) == fmi2Error, "NULL c");
    CHECK(fmi2DoStep(NULL, 0, 1e-3, 1) == fmi2Error, "NULL c");
    CHECK(fmi2GetFMUstate(NULL, &st) == fmi2Error, "NULL c");
    CHECK(fmi2SerializedFMUstateSize(NULL, st, &n) == fmi2Error, "NULL c");
    fmi2FreeInstance(NULL);
    c = started("S1", 0.0);
    CHECK(c != NULL, "instantiate");
    if (!c) return;
    /* NULL arrays, categories, strings */
    CHECK(fmi2GetReal(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2SetReal(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2GetInteger(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2GetBoolean(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2GetString(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2SetString(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2SetInteger(c, NULL, 3, NULL) == fmi2Error, "NULL arrays");
    CHECK(fmi2SetDebugLogging(c, 1, 2, NULL) != fmi2OK, "NULL categories");
    CHECK(fmi2SetDebugLogging(c, 1, 2, cats) != fmi2OK, "a NULL category");
    cats[1] = "%s%s%s%n";
    CHECK(fmi2SetDebugLogging(c, 1, 2, cats) != fmi2OK, "a format category");
    CHECK(fmi2SetString(c, &vr0, 1, bad) != fmi2OK, "NULL string");
    CHECK(fmi2GetFMUstate(c, NULL) == fmi2Error, "NULL state pointer");
    CHECK(fmi2SetFMUstate(c, NULL) == fmi2Error, "NULL state");
    CHECK(fmi2FreeFMUstate(c, NULL) == fmi2OK, "free NULL");
    CHECK(fmi2SerializedFMUstateSize(c, NULL, NULL) == fmi2Error, "NULL size");
    CHECK(fmi2SerializeFMUstate(c, NULL, NULL, 0) == fmi2Error, "NULL state");
    CHECK(fmi2DeSerializeFMUstate(c, NULL, 0, &st) == fmi2Error, "NULL bytes");
    fmi2FreeInstance(c);
}

/* printf directives in every string the FMU reads, with logging on */
static void formats(void)
{
    static const char *const hostile[] = {"%s%s%s%s", "%n%n%n", "%x%x%x%x%p", "%999999999d",
                                          "%.99999f", "S1%", "%", "\xff\xfe%s", ""};
    const fmi2ValueReference vr_mode = 0;
    size_t i;
    fmi2Component c = started("S1", 0.0);
    if (!c) return;
    fmi2Reset(c);
    fmi2SetDebugLogging(c, 1, 0, NULL);
    for (i = 0; i < sizeof hostile / sizeof *hostile; i++) {
        fmi2String v[1];
        v[0] = hostile[i];
        CHECK(fmi2SetString(c, &vr_mode, 1, v) == fmi2Error, "mode %s accepted", hostile[i]);
        CHECK(fmi2Instantiate(hostile[i], fmi2CoSimulation, hostile[i], hostile[i], &CB, 0, 1)
              == NULL, "GUID %s accepted", hostile[i]);
    }
    fmi2FreeInstance(c);
}

/* inputs at and beyond every edge of the map, in every mode */
static void edges(void)
{
    static const char *const modes[] = {"12", "21", "1S", "S1", "2S", "S2"};
    double w_low = CD_MAP.w_low, ws[64], taus[64];
    int nw = 0, nt = 0, m, i, j, k;
    double lo = exp(CD_MAP.lw[0]), hi = exp(CD_MAP.lw[CD_MAP.n_speed - 1]);
    double tlo = exp(CD_MAP.lt[0]), thi = exp(CD_MAP.lt[CD_MAP.n_torque - 1]);
    double w = w_low, t = tlo, wh = hi, th = thi;
    for (k = 0; k < 8; k++) {   /* ulps around each edge */
        ws[nw++] = w; ws[nw++] = -w; ws[nw++] = wh; ws[nw++] = -wh;
        taus[nt++] = t; taus[nt++] = -t; taus[nt++] = th; taus[nt++] = -th;
        w = nextafter(w, k < 4 ? 0 : 1e9); wh = nextafter(wh, k < 4 ? 0 : 1e9);
        t = nextafter(t, k < 4 ? 0 : 1e9); th = nextafter(th, k < 4 ? 0 : 1e9);
    }
    ws[nw++] = 0.0; ws[nw++] = -0.0; ws[nw++] = 5e-324; ws[nw++] = lo * 0.999999;
    ws[nw++] = 1e300; ws[nw++] = -1e308; ws[nw++] = 2.2250738585072014e-308;
    taus[nt++] = 0.0; taus[nt++] = 5e-324; taus[nt++] = 1e300; taus[nt++] = -1e308;
    for (m = 0; m < CD_N_MODES; m++) {
        fmi2Component c = started(modes[m], m % 2 ? 2e-3 : 0.0);
        CDSolution r;
        if (!c) continue;
        for (i = 0; i < nw; i++)
            for (j = 0; j < nt; j++) {
                cd_solve(&CD_MAP, m, ws[i], taus[j], &r);
                step(c, (double)(i * nt + j) * 1e-3, ws[i], taus[j], (i + j) % 3 ? 0.0 : 1e3);
            }
        fmi2FreeInstance(c);
    }
}

/* The speed grid's first node one ulp above log(w_low): w_low and the speeds just above it
 * then lie below the table in ln w (exp and log round; the map of another design or range can
 * be built that way), which must clamp, not index before the table. */
static void edge_of_rounding(void)
{
    static double lw[512];
    CDMap map = CD_MAP;
    CDSolution r;
    double w;
    int m, k;
    if (map.n_speed > 512) return;
    memcpy(lw, CD_MAP.lw, sizeof(double) * (size_t)map.n_speed);
    lw[0] = nextafter(log(map.w_low), 1.0);
    map.lw = lw;
    for (m = 0; m < CD_N_MODES; m++)
        for (k = 0, w = map.w_low; k < 4; k++, w = nextafter(w, 1e9)) {
            cd_solve(&map, m, w, -3.0, &r);
            CHECK(isfinite(r.torques[0]) && isfinite(r.losses[5]), "edge of rounding");
        }
}

/* every 8-byte and 4-byte field of a serialised state overwritten with hostile values */
static void corrupted_states(void)
{
    static const double dbl[] = {NAN, INFINITY, -INFINITY, -1.0, 0.0, 1e308, -1e308, 5e-324};
    static const int ints[] = {-1, 2147483647, -2147483647 - 1, 7, 2};
    fmi2Component c = started("S1", 2e-3);
    fmi2FMUstate st = NULL, got = NULL;
    size_t n = 0, off;
    unsigned char *blob, *bad;
    unsigned int seed = 12345u;
    int k, accepted = 0;
    if (!c) return;
    step(c, 0.0, 100.0, -3.0, 10.0);
    fmi2GetFMUstate(c, &st);
    fmi2SerializedFMUstateSize(c, st, &n);
    blob = malloc(n);
    bad = malloc(n);
    fmi2SerializeFMUstate(c, st, blob, n);
    for (off = 40; off + 8 <= n; off += 4) {
        for (k = 0; k < (int)(sizeof dbl / sizeof *dbl) + (int)(sizeof ints / sizeof *ints); k++) {
            memcpy(bad, blob, n);
            if (k < 8) {
                if (off % 8) continue;
                memcpy(bad + off, &dbl[k], 8);
            } else {
                memcpy(bad + off, &ints[k - 8], 4);
            }
            got = NULL;
            if (fmi2DeSerializeFMUstate(c, bad, n, &got) == fmi2OK) {
                accepted++;
                if (fmi2SetFMUstate(c, got) == fmi2OK) {
                    step(c, 1.0, 120.0, -4.0, 0.0);
                    step(c, 1.001, 120.0, -4.0, 5.0);
                }
                fmi2FreeFMUstate(c, &got);
            }
        }
    }
    /* random bytes */
    for (k = 0; k < iterations * 20; k++) {
        size_t i, flips = 1 + (seed >> 28);
        memcpy(bad, blob, n);
        for (i = 0; i < flips; i++) {
            seed = seed * 1103515245u + 12345u;
            bad[40 + (seed >> 8) % (n - 40)] ^= (unsigned char)(1u << ((seed >> 4) & 7));
        }
        got = NULL;
        if (fmi2DeSerializeFMUstate(c, bad, n, &got) == fmi2OK) {
            if (fmi2SetFMUstate(c, got) == fmi2OK) step(c, 2.0, 80.0, -2.0, 0.0);
            fmi2FreeFMUstate(c, &got);
        }
    }
    /* wrong sizes */
    got = NULL;
    CHECK(fmi2DeSerializeFMUstate(c, blob, n - 1, &got) == fmi2Error, "short state");
    CHECK(fmi2SerializeFMUstate(c, st, bad, n - 1) == fmi2Error, "short buffer");
    fmi2FreeFMUstate(c, &st);
    free(blob);
    free(bad);
    fmi2FreeInstance(c);
    fprintf(stderr, "  corrupted states: %d single-field corruptions accepted (valid values)\n",
            accepted);
}

static void *worker(void *arg)
{
    static const char *const modes[] = {"12", "21", "1S", "S1", "2S", "S2"};
    long id = (long)arg;
    int k;
    for (k = 0; k < iterations; k++) {
        fmi2Component c = started(modes[(id + k) % 6], (k % 3) * 1e-3);
        fmi2FMUstate st = NULL;
        if (!c) continue;
        step(c, 0.0, 50.0 + id + k, -1.0 - k % 5, 0.0);
        fmi2GetFMUstate(c, &st);
        step(c, 1e-3, 60.0, -2.0, 3.0);
        fmi2SetFMUstate(c, st);
        fmi2FreeFMUstate(c, &st);
        fmi2Terminate(c);
        fmi2FreeInstance(c);
    }
    return NULL;
}

static void threads(void)
{
    pthread_t th[8];
    long i;
    for (i = 0; i < 8; i++) pthread_create(&th[i], NULL, worker, (void *)i);
    for (i = 0; i < 8; i++) pthread_join(th[i], NULL);
}

int main(int argc, char **argv)
{
    int i;
    if (argc > 1) iterations = atoi(argv[1]);
    for (i = 0; i < 20; i++) OUT_VR[i] = 10 + (fmi2ValueReference)i;
    if (argc > 2 && strcmp(argv[2], "threads") == 0) {   /* the ThreadSanitizer run */
        threads();
        fprintf(stderr, "host_native (threads only): %d problems\n", problems);
        return problems ? 1 : 0;
    }
    nulls();
    formats();
    edges();
    edge_of_rounding();
    corrupted_states();
    threads();
    fprintf(stderr, "host_native: %d problems\n", problems);
    return problems ? 1 : 0;
}
