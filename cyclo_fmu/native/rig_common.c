/* Shared arithmetic of the native bench components: each function is the C twin of the
 * model_core.rig function named in rig_model.h, written to round as the Python does (no fused
 * multiply-add: compiled with -ffp-contract=off). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rig_model.h"

int rig_finite(double v) { return isfinite(v) != 0; }

/* CPython's float_floor_div (Objects/floatobject.c, float_divmod), for finite a, b != 0 */
double rig_floordiv(double a, double b)
{
    double mod = fmod(a, b), div = (a - mod) / b, floordiv;
    if (mod != 0.0) {
        if ((b < 0) != (mod < 0)) div -= 1.0;
    }
    if (div != 0.0) {
        floordiv = floor(div);
        if (div - floordiv > 0.5) floordiv += 1.0;
    } else {
        floordiv = copysign(0.0, a / b);
    }
    return floordiv;
}

double rig_series_value(double t, double first, double last, int count, double hold,
                        int repeat)
{
    long long slot, i;
    if (count <= 1 || hold <= 0) return first;
    slot = (long long)rig_floordiv(t > 0.0 ? t : 0.0, hold);
    if (repeat < 1) repeat = 1;
    /* Python's // and % on non-negative integers */
    i = (slot / repeat) % count;
    return first + (last - first) * (double)i / (double)(count - 1);
}

double rig_schedule_value(const RigState *s, double t)
{
    int k;
    double v;
    if (s->n_schedule <= 0) return 0.0;
    v = s->schedule[0][1];
    for (k = 0; k < s->n_schedule; k++) {
        if (s->schedule[k][0] <= t + 1e-12) v = s->schedule[k][1];
        else break;
    }
    return v;
}

static int add_point(RigState *s, double t, double v, const char *what, char *msg, size_t n)
{
    if (!isfinite(t) || !isfinite(v)) {
        snprintf(msg, n, "%s: times and values must be finite", what);
        return 1;
    }
    if (s->n_schedule >= RIG_MAX_SCHEDULE) {
        snprintf(msg, n, "%s: more than %d setpoints", what, RIG_MAX_SCHEDULE);
        return 1;
    }
    if (s->n_schedule > 0 && t < s->schedule[s->n_schedule - 1][0]) {
        snprintf(msg, n, "%s: times must increase", what);
        return 1;
    }
    s->schedule[s->n_schedule][0] = t;
    s->schedule[s->n_schedule][1] = v;
    s->n_schedule++;
    return 0;
}

int rig_load_schedule(RigState *s, const char *text_name, const char *text, int count,
                      const double *times, const double *values, char *msg, size_t n)
{
    const char *p = text;
    int blank = 1, k;
    for (; *p; p++)
        if (*p != ' ' && *p != '\t' && *p != '\n' && *p != '\r') { blank = 0; break; }
    s->n_schedule = -1;
    if (!blank && count) {
        snprintf(msg, n, "%s and schedule_points = %d: give the schedule one way", text_name,
                 count);
        return 1;
    }
    if (!blank) {
        /* 't0 v0; t1 v1; ...' (',' counts as a blank), as model_core.rig.parse_schedule */
        char buf[RIG_STRLEN];
        char *entry, *next;
        size_t i;
        snprintf(buf, sizeof buf, "%s", text);
        for (i = 0; buf[i]; i++) if (buf[i] == ',') buf[i] = ' ';
        s->n_schedule = 0;
        for (entry = buf; entry; entry = next) {
            char *end1, *end2, *q;
            next = strchr(entry, ';');
            if (next) *next++ = '\0';
            double t, v;
            for (q = entry; *q == ' ' || *q == '\t' || *q == '\n' || *q == '\r'; q++) {}
            if (!*q) continue;
            t = strtod(q, &end1);
            v = end1 == q ? 0.0 : strtod(end1, &end2);
            if (end1 == q || end2 == end1) {
                snprintf(msg, n, "%s: each entry must be 'time value'", text_name);
                return 1;
            }
            for (q = end2; *q == ' ' || *q == '\t' || *q == '\n' || *q == '\r'; q++) {}
            if (*q) {
                snprintf(msg, n, "%s: each entry must be 'time value'", text_name);
                return 1;
            }
            if (add_point(s, t, v, text_name, msg, n)) return 1;
        }
        if (s->n_schedule == 0) {
            snprintf(msg, n, "%s: needs at least one entry", text_name);
            return 1;
        }
        return 0;
    }
    if (count < 0 || count > 8) {
        snprintf(msg, n, "schedule_points = %d: must be 0 to 8", count);
        return 1;
    }
    if (count == 0) return 0;
    s->n_schedule = 0;
    for (k = 0; k < count; k++)
        if (add_point(s, times[k], values[k], "schedule_time_k, schedule_value_k", msg, n))
            return 1;
    return 0;
}

/* SplitMix64's output function (Steele, Lea and Flood 2014) */
static unsigned long long mix64(unsigned long long z)
{
    z ^= z >> 30;
    z *= 0xBF58476D1CE4E5B9ULL;
    z ^= z >> 27;
    z *= 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return z;
}

#define GOLDEN 0x9E3779B97F4A7C15ULL

/* Standard-normal sample k of stream seed: counter-based (SplitMix64 over the counter), one
 * Box-Muller pair per sample (cosine branch). model_core.rig.normal_samples is the same. */
double rig_normal_sample(unsigned long long seed, unsigned long long k)
{
    const double two_pi = 6.283185307179586;
    unsigned long long base = mix64(seed + GOLDEN);
    unsigned long long z1 = mix64(base + (2 * k + 1) * GOLDEN);
    unsigned long long z2 = mix64(base + (2 * k + 2) * GOLDEN);
    double u1 = ((double)(z1 >> 11) + 1.0) * 0x1.0p-53;   /* (0, 1] */
    double u2 = (double)(z2 >> 11) * 0x1.0p-53;           /* [0, 1) */
    return sqrt(-2.0 * log(u1)) * cos(two_pi * u2);
}
