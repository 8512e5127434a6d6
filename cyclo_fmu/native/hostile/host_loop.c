/* A hostile caller of the bench loop (bench_loop.c), compiled with it under AddressSanitizer and
 * UndefinedBehaviorSanitizer (cyclo_fmu/native/sanitize.py): a valid two-component run with
 * fake FMU functions, then every count, offset and index pushed one past its buffer, NULL
 * arrays and bad step sizes, each of which must be refused (-1) before any call.
 * cyclo-fmu, MIT license. */
#include <math.h>
#include <stdio.h>
#include <string.h>

long bench_loop(int n_comp, void **comps, void **set_fns, void **step_fns, void **get_fns,
                unsigned int **in_vrs, const size_t *n_in, const int *in_off,
                unsigned int **out_vrs, const size_t *n_out, const int *out_off,
                const int *link_start, const int *dst, const int *src, int gauss,
                double *buf, int buf_len, double *rows, long rows_cap, int row_len, long k0,
                long n_steps, double step, int *fail, int n_ext, const int *ext_dst,
                const double *ext);

static double state[2];

static int set_real(void *c, const unsigned int *vr, size_t n, const double *v)
{
    (void)vr; (void)n;
    state[(long)c - 1] = v[0];
    return 0;
}
static int do_step(void *c, double t, double h, int np) { (void)c; (void)t; (void)h; (void)np; return 0; }
static int get_real(void *c, const unsigned int *vr, size_t n, double *v)
{
    (void)vr; (void)n;
    v[0] = state[(long)c - 1] + 1.0;
    return 0;
}

int main(void)
{
    void *comps[2] = {(void *)1, (void *)2};
    void *sets[2] = {(void *)set_real, (void *)set_real};
    void *steps[2] = {(void *)do_step, (void *)do_step};
    void *gets[2] = {(void *)get_real, (void *)get_real};
    unsigned int vr[1] = {0};
    unsigned int *vrs[2] = {vr, vr};
    size_t n_in[2] = {1, 1}, n_out[2] = {1, 1};
    int in_off[2] = {2, 3}, out_off[2] = {0, 1};
    int link_start[3] = {0, 1, 2}, dst[2] = {2, 3}, src[2] = {1, 0};
    double buf[4] = {0}, rows[4 * 10];
    int fail[3], problems = 0, i;
    long r = bench_loop(2, comps, sets, steps, gets, vrs, n_in, in_off, vrs, n_out, out_off,
                        link_start, dst, src, 1, buf, 4, rows, 10, 4, 0, 10, 1e-3, fail,
                        0, NULL, NULL);
    if (r != 0 || rows[4 * 9] < 9) { problems++; fprintf(stderr, "valid run: %ld\n", r); }
#define BAD(stmt, label) do { \
        size_t n_in2[2] = {1, 1}, n_out2[2] = {1, 1}; \
        int in2[2] = {2, 3}, out2[2] = {0, 1}, ls2[3] = {0, 1, 2}, d2[2] = {2, 3}, s2[2] = {1, 0}; \
        long cap = 10, steps_n = 10; int blen = 4, rlen = 4; double h = 1e-3; \
        void **cp = comps; \
        stmt; \
        r = bench_loop(2, cp, sets, steps, gets, vrs, n_in2, in2, vrs, n_out2, out2, ls2, d2, s2, \
                       1, buf, blen, rows, cap, rlen, 0, steps_n, h, fail, 0, NULL, NULL); \
        if (r != -1) { problems++; fprintf(stderr, "not refused: %s (%ld)\n", label, r); } \
    } while (0)
    BAD(in2[1] = 4, "input offset past the buffer");
    BAD(n_in2[0] = 3, "input count past the buffer");
    BAD(out2[0] = -1, "negative output offset");
    BAD(n_out2[1] = (size_t)1 << 62, "huge output count");
    BAD(d2[1] = 4, "link destination past the buffer");
    BAD(s2[0] = -5, "negative link source");
    BAD(ls2[1] = 5, "link range past the links");
    BAD(ls2[0] = 1, "links not starting at 0");
    BAD(cap = 9, "more steps than rows");
    BAD(rlen = 5, "row width not the buffer's");
    BAD(blen = 0, "empty buffer");
    BAD(steps_n = -1, "negative step count");
    BAD(h = NAN, "NaN step");
    BAD(h = -1e-3, "negative step");
    BAD(cp = NULL, "NULL components");
    {   /* the external signals of a replay: a bad count or destination is refused too */
        int ext_dst[1] = {4};
        double ext[10] = {0};
        r = bench_loop(2, comps, sets, steps, gets, vrs, n_in, in_off, vrs, n_out, out_off,
                       link_start, dst, src, 1, buf, 4, rows, 10, 4, 0, 10, 1e-3, fail,
                       1, ext_dst, ext);
        if (r != -1) { problems++; fprintf(stderr, "not refused: external past the buffer\n"); }
        r = bench_loop(2, comps, sets, steps, gets, vrs, n_in, in_off, vrs, n_out, out_off,
                       link_start, dst, src, 1, buf, 4, rows, 10, 4, 0, 10, 1e-3, fail,
                       -1, NULL, NULL);
        if (r != -1) { problems++; fprintf(stderr, "not refused: negative external count\n"); }
    }
    for (i = 0; i < 3; i++) (void)fail[i];
    fprintf(stderr, "host_loop: %d problems\n", problems);
    return problems ? 1 : 0;
}
