/* The lean bench master's inner loop (cyclo_fmu.bench.run_fmus): fixed-step co-simulation of
 * FMI 2.0 co-simulation slaves over value references and buffers resolved by the Python side.
 * The same calls, in the same order, as the Python loop it replaces (which stays as the
 * fallback without a C compiler); only the interpreter's per-call overhead goes.
 *
 * buf: every output, then every input (doubles). A component c reads its inputs from
 * buf[in_off[c] .. in_off[c] + n_in[c]) and writes its outputs to buf[out_off[c] ..).
 * Gauss-Seidel: before component c, buf[dst[l]] = buf[src[l]] for its links l in
 * [link_start[c], link_start[c + 1]); Jacobi: all links after the step. After each step the
 * whole buffer is appended to rows.
 *
 * External signals (a replay's measured setpoints): before step k the n_ext values
 * ext[(k - k0) * n_ext + j] are written to buf[ext_dst[j]] (inputs no connection feeds).
 *
 * Returns 0, or the failing step (k + 1) with fail[0] = component, fail[1] = function
 * (0 fmi2SetReal, 1 fmi2DoStep, 2 fmi2GetReal) and fail[2] = its status; or -1 before any
 * call if an argument is inconsistent (fail[0] = the check that failed, fail[1] = the
 * component or link): counts, offsets and indices are checked against buf_len and rows_cap
 * (rows of row_len doubles available at rows), so that no call writes outside the buffers. */
#include <stddef.h>
#include <string.h>

typedef int (*set_real_t)(void *, const unsigned int *, size_t, const double *);
typedef int (*get_real_t)(void *, const unsigned int *, size_t, double *);
typedef int (*do_step_t)(void *, double, double, int);

long bench_loop(int n_comp, void **comps, void **set_fns, void **step_fns, void **get_fns,
                unsigned int **in_vrs, const size_t *n_in, const int *in_off,
                unsigned int **out_vrs, const size_t *n_out, const int *out_off,
                const int *link_start, const int *dst, const int *src, int gauss,
                double *buf, int buf_len, double *rows, long rows_cap, int row_len, long k0,
                long n_steps, double step, int *fail, int n_ext, const int *ext_dst,
                const double *ext)
{
    int n_links;
    if (fail == NULL) return -1;
#define BAD(check, which) do { fail[0] = (check); fail[1] = (which); fail[2] = 0; return -1; } \
    while (0)
    if (n_comp <= 0 || !comps || !set_fns || !step_fns || !get_fns || !in_vrs || !n_in
        || !in_off || !out_vrs || !n_out || !out_off || !link_start || !buf || !rows)
        BAD(1, 0);
    if (buf_len <= 0 || row_len != buf_len || n_steps < 0 || k0 < 0 || n_steps > rows_cap
        || !(step > 0) || step != step || step > 1e300)
        BAD(2, 0);
    if (link_start[0] != 0) BAD(3, 0);
    for (int c = 0; c < n_comp; ++c) {
        if (!comps[c] || !step_fns[c]) BAD(4, c);
        if (link_start[c + 1] < link_start[c]) BAD(3, c);
        if (n_in[c] && (!set_fns[c] || !in_vrs[c] || in_off[c] < 0
                        || n_in[c] > (size_t)buf_len - (size_t)in_off[c]))
            BAD(5, c);
        if (n_out[c] && (!get_fns[c] || !out_vrs[c] || out_off[c] < 0
                         || n_out[c] > (size_t)buf_len - (size_t)out_off[c]))
            BAD(6, c);
    }
    n_links = link_start[n_comp];
    if (n_links > 0 && (!dst || !src)) BAD(7, 0);
    for (int l = 0; l < n_links; ++l)
        if (dst[l] < 0 || dst[l] >= buf_len || src[l] < 0 || src[l] >= buf_len) BAD(7, l);
    if (n_ext < 0 || (n_ext > 0 && (!ext_dst || !ext))) BAD(8, 0);
    for (int j = 0; j < n_ext; ++j)
        if (ext_dst[j] < 0 || ext_dst[j] >= buf_len) BAD(8, j);
#undef BAD
    for (long k = k0; k < k0 + n_steps; ++k) {
        double t = (double)k * step;
        for (int j = 0; j < n_ext; ++j)
            buf[ext_dst[j]] = ext[(size_t)(k - k0) * (size_t)n_ext + (size_t)j];
        for (int c = 0; c < n_comp; ++c) {
            int status;
            if (n_in[c]) {
                if (gauss)
                    for (int l = link_start[c]; l < link_start[c + 1]; ++l)
                        buf[dst[l]] = buf[src[l]];
                status = ((set_real_t)set_fns[c])(comps[c], in_vrs[c], n_in[c], buf + in_off[c]);
                if (status > 1) { fail[0] = c; fail[1] = 0; fail[2] = status; return k + 1; }
            }
            status = ((do_step_t)step_fns[c])(comps[c], t, step, 1);
            if (status > 1) { fail[0] = c; fail[1] = 1; fail[2] = status; return k + 1; }
            if (n_out[c]) {
                status = ((get_real_t)get_fns[c])(comps[c], out_vrs[c], n_out[c], buf + out_off[c]);
                if (status > 1) { fail[0] = c; fail[1] = 2; fail[2] = status; return k + 1; }
            }
        }
        if (!gauss)
            for (int l = 0; l < n_links; ++l)
                buf[dst[l]] = buf[src[l]];
        memcpy(rows + (size_t)(k - k0) * (size_t)buf_len, buf, sizeof(double) * (size_t)buf_len);
    }
    return 0;
}
