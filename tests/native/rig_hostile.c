/* Hostile host for the native bench components (compiled with ASan and UBSan by
 * tests/test_native_sanitize.py together with one component's sources): NULLs everywhere,
 * format directives in strings, every value reference with extreme values, corrupted and
 * truncated states, calls out of order, a host allocator without a free, and threads creating,
 * stepping and freeing instances at once. The sanitizers abort on any memory or undefined-
 * behaviour fault; the checks below fail (exit 1) on a wrong status. */
#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

static const char *GUID;
static int failures;
static int percent_seen;

#define EXPECT(cond) do { if (!(cond)) { fprintf(stderr, "FAILED line %d: %s\n", __LINE__, #cond); failures++; } } while (0)

/* a logger that formats the message again, as some hosts do: a '%' reaching it would be a
 * format-string hole */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    char buf[2048];
    va_list ap;
    (void)env; (void)name; (void)status; (void)category;
    if (message == NULL) return;
    if (strchr(message, '%')) { percent_seen = 1; return; }
    va_start(ap, message);
    vsnprintf(buf, sizeof buf, message, ap);   /* safe only because no '%' is left */
    va_end(ap);
}

static void *only_alloc(size_t n, size_t size) { return calloc(n, size); }

static fmi2CallbackFunctions CB = {logger, NULL, NULL, NULL, NULL};

static fmi2Component make(void)
{
    return fmi2Instantiate("hostile", fmi2CoSimulation, GUID, "file:///", &CB, fmi2False, fmi2True);
}

static void nulls(void)
{
    fmi2ValueReference vr = 0;
    fmi2Real r = 0;
    fmi2Component c;
    c = fmi2Instantiate(NULL, fmi2CoSimulation, GUID, NULL, NULL, 0, 0);   /* no callbacks */
    EXPECT(c != NULL);
    fmi2FreeInstance(c);
    EXPECT(fmi2Instantiate("x", fmi2CoSimulation, NULL, NULL, &CB, 0, 0) == NULL);
    EXPECT(fmi2Instantiate("x", fmi2CoSimulation, "{bad}", NULL, &CB, 0, 0) == NULL);
    EXPECT(fmi2Instantiate("x", fmi2ModelExchange, GUID, NULL, &CB, 0, 0) == NULL);
    EXPECT(fmi2SetupExperiment(NULL, 0, 0, 0, 0, 0) == fmi2Error);
    EXPECT(fmi2DoStep(NULL, 0, 1e-3, 1) == fmi2Error);
    EXPECT(fmi2GetReal(NULL, &vr, 1, &r) == fmi2Error);
    EXPECT(fmi2SetDebugLogging(NULL, 1, 0, NULL) == fmi2Error);
    fmi2FreeInstance(NULL);
    c = make();
    EXPECT(c != NULL);
    EXPECT(fmi2GetReal(c, NULL, 1, &r) == fmi2Error);
    EXPECT(fmi2GetReal(c, &vr, 1, NULL) == fmi2Error);
    EXPECT(fmi2SetReal(c, NULL, 1, NULL) == fmi2Error);
    EXPECT(fmi2SetString(c, &vr, 1, NULL) == fmi2Error);
    EXPECT(fmi2SetDebugLogging(c, 1, 2, NULL) == fmi2Error);
    {
        const char *cats[] = {"logAll", NULL};
        EXPECT(fmi2SetDebugLogging(c, 1, 2, cats) == fmi2Error);
    }
    EXPECT(fmi2DoStep(c, 0, 1e-3, 1) == fmi2Error);              /* out of order */
    EXPECT(fmi2ExitInitializationMode(c) == fmi2Error);
    EXPECT(fmi2GetFMUstate(c, NULL) == fmi2Error);
    EXPECT(fmi2SetFMUstate(c, NULL) == fmi2Error);
    fmi2FreeInstance(c);
}

/* every value reference 0..300 of every type: extreme values, hostile strings */
static void everything(void)
{
    static const double reals[] = {0.0, -0.0, 1e308, -1e308, 5e-324, NAN, INFINITY, -INFINITY};
    static const int ints[] = {0, -1, 2147483647, -2147483647 - 1};
    const char *strings[] = {"%s%s%s%s%n%x", "0:%s%s%s%s", "", ";;;", "1e400 5; 0 nan",
                             "0 1; -1 2", "0 1 2", "abc"};
    char longs[5000];
    fmi2Component c = make();
    fmi2ValueReference vr;
    size_t k;
    memset(longs, '%', sizeof longs - 1);
    longs[sizeof longs - 1] = '\0';
    fmi2SetupExperiment(c, 0, 0, 0, 0, 0);
    fmi2EnterInitializationMode(c);
    for (vr = 0; vr < 300; vr++) {
        fmi2Real r;
        fmi2Integer i;
        fmi2Boolean b;
        fmi2String s;
        for (k = 0; k < sizeof reals / sizeof *reals; k++) {
            fmi2SetReal(c, &vr, 1, &reals[k]);
            fmi2GetReal(c, &vr, 1, &r);
        }
        for (k = 0; k < sizeof ints / sizeof *ints; k++) {
            i = ints[k];
            fmi2SetInteger(c, &vr, 1, &i);
            fmi2GetInteger(c, &vr, 1, &i);
        }
        b = fmi2True;
        fmi2SetBoolean(c, &vr, 1, &b);
        fmi2GetBoolean(c, &vr, 1, &b);
        for (k = 0; k < sizeof strings / sizeof *strings; k++) {
            s = strings[k];
            fmi2SetString(c, &vr, 1, &s);
            if (fmi2GetString(c, &vr, 1, &s) == fmi2OK) EXPECT(s != NULL);
            fmi2ExitInitializationMode(c);   /* refused or not: never a crash */
        }
        s = longs;
        fmi2SetString(c, &vr, 1, &s);
    }
    fmi2ExitInitializationMode(c);
    for (k = 0; k < 50; k++) fmi2DoStep(c, k * 1e-3, 1e-3, 1);
    fmi2DoStep(c, 0, -1, 1);
    fmi2DoStep(c, NAN, 1e-3, 1);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
}

static void states(void)
{
    fmi2Component c = make();
    fmi2FMUstate st = NULL, other = NULL;
    size_t size = 0, k;
    fmi2Byte *buf, *bad;
    unsigned int seed = 7;
    fmi2SetupExperiment(c, 0, 0, 0, 0, 0);
    fmi2EnterInitializationMode(c);
    EXPECT(fmi2ExitInitializationMode(c) == fmi2OK);
    for (k = 0; k < 20; k++) fmi2DoStep(c, k * 1e-3, 1e-3, 1);
    EXPECT(fmi2GetFMUstate(c, &st) == fmi2OK);
    EXPECT(fmi2SerializedFMUstateSize(c, st, &size) == fmi2OK && size > 48);
    buf = (fmi2Byte *)malloc(size);
    bad = (fmi2Byte *)malloc(size);
    EXPECT(fmi2SerializeFMUstate(c, st, buf, size) == fmi2OK);
    EXPECT(fmi2SerializeFMUstate(c, st, buf, size - 1) == fmi2Error);
    EXPECT(fmi2DeSerializeFMUstate(c, buf, size - 1, &other) == fmi2Error);
    EXPECT(fmi2DeSerializeFMUstate(c, buf, size, &other) == fmi2OK);
    EXPECT(fmi2SetFMUstate(c, other) == fmi2OK);
    /* random corruption after the GUID: refused or a valid state, never a crash or NaN */
    for (k = 0; k < 2000; k++) {
        fmi2FMUstate s2 = NULL;
        size_t j, n = 1 + rand_r(&seed) % 8;
        memcpy(bad, buf, size);
        for (j = 0; j < n; j++) bad[48 + rand_r(&seed) % (size - 48)] = (fmi2Byte)rand_r(&seed);
        if (fmi2DeSerializeFMUstate(c, bad, size, &s2) == fmi2OK) {
            fmi2ValueReference vr;
            EXPECT(fmi2SetFMUstate(c, s2) == fmi2OK);
            for (j = 0; j < 10; j++) fmi2DoStep(c, 0.02 + j * 1e-3, 1e-3, 1);
            for (vr = 0; vr < 300; vr++) {
                fmi2Real r;
                if (fmi2GetReal(c, &vr, 1, &r) == fmi2OK) EXPECT(!isnan(r));
            }
            fmi2FreeFMUstate(c, &s2);
            EXPECT(fmi2SetFMUstate(c, st) == fmi2OK);
        }
    }
    memset(bad, 0xff, size);
    EXPECT(fmi2DeSerializeFMUstate(c, bad, size, &other) == fmi2Error);
    fmi2FreeFMUstate(c, &st);
    fmi2FreeFMUstate(c, &other);
    free(buf);
    free(bad);
    fmi2FreeInstance(c);
}

static void alloc_without_free(void)
{
    fmi2CallbackFunctions cb = {logger, only_alloc, NULL, NULL, NULL};
    fmi2Component c = fmi2Instantiate("x", fmi2CoSimulation, GUID, NULL, &cb, 0, 0);
    EXPECT(c != NULL);
    fmi2FreeInstance(c);    /* freed with free(): calloc gave it (the host's alloc is unused) */
}

static void *worker(void *arg)
{
    int k, j;
    (void)arg;
    for (k = 0; k < 100; k++) {
        fmi2Component c = make();
        if (c == NULL) { failures++; continue; }
        fmi2SetupExperiment(c, 0, 0, 0, 0, 0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        for (j = 0; j < 20; j++) fmi2DoStep(c, j * 1e-3, 1e-3, 1);
        fmi2FreeInstance(c);
    }
    return NULL;
}

int main(int argc, char **argv)
{
    pthread_t t[8];
    int k;
    if (argc < 2) return 2;
    GUID = argv[1];
    nulls();
    everything();
    states();
    alloc_without_free();
    for (k = 0; k < 8; k++) pthread_create(&t[k], NULL, worker, NULL);
    for (k = 0; k < 8; k++) pthread_join(t[k], NULL);
    EXPECT(!percent_seen);
    if (failures) fprintf(stderr, "%d failures\n", failures);
    else printf("hostile host: all checks passed\n");
    return failures ? 1 : 0;
}
