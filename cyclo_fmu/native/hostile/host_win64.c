/* A small Windows host (mingw-w64, run under wine in tests/test_platforms.py) for the win64
 * DLL of an FMU: it loads the DLL, makes the misuse calls a front must refuse (NULL handles
 * and names, another GUID, Model Exchange), then instantiates with the right GUID and, when
 * that works, initialises, steps and reads value references. One line per result on stdout:
 *   instantiate-<case> NULL|handle      log <status> <message>      step <k> <status>
 *   get <vr> <value>                    call-<fn> <status>
 *
 * usage: host_win64 <dll> <guid> <resource-uri> [steps [vr | vr=value ...]]
 *   vr=value: a Real set before initialisation; vr: a Real read after the steps
 * cyclo-fmu, MIT license. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <windows.h>

#include "fmi2Functions.h"

/* a logger that prints the text as it is (never formats it) */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status st, fmi2String cat,
                   fmi2String msg, ...)
{
    (void)env; (void)name; (void)cat;
    printf("log %d %s\n", (int)st, msg ? msg : "(null)");
}

#define LOAD(T, n) T##TYPE *n = (T##TYPE *)(void *)GetProcAddress(dll, #T)

int main(int argc, char **argv)
{
    HMODULE dll;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c;
    int steps, k, i;
    if (argc < 4) {
        fprintf(stderr, "usage: host_win64 <dll> <guid> <resource-uri> [steps [vr ...]]\n");
        return 2;
    }
    dll = LoadLibraryA(argv[1]);
    if (dll == NULL) {
        printf("loadlibrary failed %lu\n", (unsigned long)GetLastError());
        return 3;
    }
    LOAD(fmi2Instantiate, inst);
    LOAD(fmi2FreeInstance, freei);
    LOAD(fmi2SetupExperiment, setup);
    LOAD(fmi2EnterInitializationMode, enter);
    LOAD(fmi2ExitInitializationMode, leave);
    LOAD(fmi2DoStep, step);
    LOAD(fmi2GetReal, getr);
    LOAD(fmi2SetReal, setr);
    LOAD(fmi2Terminate, term);
    if (!inst || !freei || !setup || !enter || !leave || !step || !getr || !setr || !term) {
        printf("missing export\n");
        return 4;
    }
    steps = argc > 4 ? atoi(argv[4]) : 0;
    printf("call-DoStep-NULL %d\n", (int)step(NULL, 0.0, 1e-3, fmi2True));
    printf("call-GetReal-NULL %d\n", (int)getr(NULL, NULL, 1, NULL));
    freei(NULL);
    c = inst(NULL, fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
    printf("instantiate-nullname %s\n", c ? "handle" : "NULL");
    if (c) freei(c);
    c = inst("x", fmi2CoSimulation, "{not-the-guid}", argv[3], &cb, fmi2False, fmi2False);
    printf("instantiate-badguid %s\n", c ? "handle" : "NULL");
    if (c) freei(c);
    c = inst("x", fmi2ModelExchange, argv[2], argv[3], &cb, fmi2False, fmi2False);
    printf("instantiate-me %s\n", c ? "handle" : "NULL");
    if (c) freei(c);
    c = inst("x", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
    printf("instantiate-ok %s\n", c ? "handle" : "NULL");
    if (c == NULL) return 0;
    printf("call-DoStep-early %d\n", (int)step(c, 0.0, 1e-3, fmi2True));
    for (i = 5; i < argc; i++)
        if (strchr(argv[i], '=')) {
            fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
            fmi2Real v = strtod(strchr(argv[i], '=') + 1, NULL);
            printf("set %u %d\n", (unsigned)vr, (int)setr(c, &vr, 1, &v));
        }
    printf("call-SetupExperiment %d\n", (int)setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    printf("call-Enter %d\n", (int)enter(c));
    printf("call-Exit %d\n", (int)leave(c));
    for (k = 0; k < steps; k++) {
        fmi2Status s = step(c, k * 1e-3, 1e-3, fmi2True);
        if (s != fmi2OK || k == steps - 1) printf("step %d %d\n", k, (int)s);
    }
    for (i = 5; i < argc; i++) {
        if (strchr(argv[i], '=')) continue;
        fmi2ValueReference vr = (fmi2ValueReference)strtoul(argv[i], NULL, 10);
        fmi2Real v = 0;
        fmi2Status s;
        s = getr(c, &vr, 1, &v);
        printf("get %u %d %.17g\n", (unsigned)vr, (int)s, v);
    }
    printf("call-Terminate %d\n", (int)term(c));
    freei(c);
    printf("done\n");
    return 0;
}
