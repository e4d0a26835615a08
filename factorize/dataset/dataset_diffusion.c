/* dataset_diffusion.c - the segment-averaged dipole. The value of an entry depends only on
 * |dx|, |dy| and how many of the segment's sample points lie in medium 1, so every possible
 * value is tabulated first and the dataset is then filled by counting, in parallel by rows. */
#include "dataset_diffusion.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void op_dipole_init(op_dipole *d, double sigma_s, double sigma_a, double eta)
{
    double st = sigma_s + sigma_a;
    double fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    double a = (1 + fdr) / (1 - fdr);
    d->alpha = sigma_s / st;
    d->sigma_tr = sqrt(3 * sigma_a * st);
    d->z_r = 1 / st;
    d->z_v = d->z_r * (1 + 4 * a / 3);
}

double op_dipole_rd(const op_dipole *d, double r)
{
    double r2 = r * r;
    double dr = sqrt(r2 + d->z_r * d->z_r), dv = sqrt(r2 + d->z_v * d->z_v);
    double s = d->sigma_tr;
    return d->alpha / (4 * M_PI) *
           (d->z_r * (s + 1 / dr) * exp(-s * dr) / (dr * dr) +
            d->z_v * (s + 1 / dv) * exp(-s * dv) / (dv * dv));
}

double op_dipole_total(double sigma_s, double sigma_a, double eta)
{
    double alpha = sigma_s / (sigma_s + sigma_a);
    double fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    double a = (1 + fdr) / (1 - fdr);
    double q = sqrt(3 * (1 - alpha));
    return alpha / 2 * (1 + exp(-4.0 / 3.0 * a * q)) * exp(-q);
}

/* Gauss-Legendre nodes and weights on [0, 1] for n points (Newton on P_n). */
static void gauss_legendre01(int n, double *x, double *w)
{
    for (int i = 0; i < n; i++) {
        double z = cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; it++) {
            double p0 = 1, p1 = z;
            for (int k = 2; k <= n; k++) {
                double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = 0.5 * (1 - z);
        w[i] = 1.0 / ((1 - z * z) * dp * dp);
    }
}

/* The difference of two uniform points in [-p/2, p/2] has the tent density (1 - |t|/p)/p on
 * [-p, p]; nodes and weights (summing to 1) integrate against it, n per half. */
static void tent_rule(int n, double p, double *t, double *w)
{
    double x[16], wx[16];
    gauss_legendre01(n, x, wx);
    for (int i = 0; i < n; i++) {
        double u = x[i] * p; /* in [0, p] */
        double wt = wx[i] * p * (1 - u / p) / p;
        t[i] = u;
        w[i] = wt;
        t[n + i] = -u;
        w[n + i] = wt;
    }
}

double op_dipole_pixel(const op_dipole *d, double cx, double cy, double px, double py, int n)
{
    if (n < 1)
        n = 1;
    if (n > 16)
        n = 16;
    double tx[32], wx[32], ty[32], wy[32];
    tent_rule(n, px, tx, wx);
    tent_rule(n, py, ty, wy);
    double sum = 0;
    for (int i = 0; i < 2 * n; i++) {
        double row = 0;
        for (int j = 0; j < 2 * n; j++)
            row += wy[j] * op_dipole_rd(d, hypot(cx + tx[i], cy + ty[j]));
        sum += wx[i] * row;
    }
    return sum * px * py;
}

/* ------------------------------------------------------------ the generator */

typedef struct offset_plan {
    int dx, dy, col;
    int first, count;   /* this offset's sample deltas: deltas[first .. first + count) */
    const float *value; /* table: value[k * 3 + c] for k = 0..count points in medium 1 */
} offset_plan;

struct op_diffusion {
    const op_layout *l;
    uint8_t *padded;           /* the map padded periodically by h on every side */
    int pw;                    /* padded width */
    int kernel, cols;
    offset_plan *plan;
    int64_t *deltas;           /* sample offsets within padded, relative to the pixel */
    float *values;             /* the tables plan[].value point into */
};

typedef struct diffusion_job {
    const op_diffusion *d;
    op_dataset *out;
    uint64_t chunk;            /* rows per task */
    op_progress *progress;
} diffusion_job;

/* Fills rows [task * chunk, + chunk) of the block (one op_parallel_for task). */
static void diffusion_rows(void *user, int task, int thread)
{
    diffusion_job *j = user;
    const op_diffusion *d = j->d;
    const op_layout *l = d->l;
    int h = d->kernel / 2;
    (void)thread;
    uint64_t first = (uint64_t)task * j->chunk, end = first + j->chunk;
    if (end > j->out->nrows)
        end = j->out->nrows;
    for (uint64_t r = first; r < end; r++) {
        uint64_t row = j->out->row0 + r;
        int x = (int)(row % (uint64_t)l->width), y = (int)(row / (uint64_t)l->width);
        const uint8_t *base = d->padded + (int64_t)(y + h) * d->pw + (x + h);
        float *out[3];
        for (int c = 0; c < 3; c++)
            out[c] = j->out->rd[c] + r * (uint64_t)d->cols;
        for (int o = 0; o < d->cols; o++) {
            const offset_plan *p = &d->plan[o];
            const int64_t *dl = d->deltas + p->first;
            int k = 0;
            for (int s = 0; s < p->count; s++)
                k += base[dl[s]];
            const float *v = p->value + 3 * k;
            out[0][p->col] = v[0];
            out[1][p->col] = v[1];
            out[2][p->col] = v[2];
        }
    }
    op_progress_advance(j->progress, end - first);
}

static int64_t floor_div(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

void op_diffusion_end(op_diffusion *d)
{
    if (!d)
        return;
    free(d->padded), free(d->values), free(d->deltas), free(d->plan);
    free(d);
}

op_status op_diffusion_begin(const op_layout *l, int K, op_diffusion **out, op_error *err)
{
    *out = NULL;
    if (K < 1 || K % 2 == 0)
        return op_error_set(err, OP_ERR_INTERNAL, "diffusion: kernel %d is not odd", K);
    int h = K / 2, cols = K * K;
    int pw = l->width + 2 * h, ph = l->height + 2 * h;
    /* Tabulated values: for quadrant offset (ax, ay), M = max(ax, ay) + 1 samples, M + 1 levels. */
    int64_t nvalues = 0, ndeltas = 0;
    for (int ay = 0; ay <= h; ay++)
        for (int ax = 0; ax <= h; ax++)
            nvalues += 3 * (int64_t)((ax > ay ? ax : ay) + 2);
    for (int o = 0; o < cols; o++) {
        int dx = o % K - h, dy = o / K - h;
        ndeltas += (abs(dx) > abs(dy) ? abs(dx) : abs(dy)) + 1;
    }
    op_diffusion *d = calloc(1, sizeof *d);
    const float **quad = malloc((size_t)(h + 1) * (size_t)(h + 1) * sizeof *quad);
    if (d) {
        d->padded = malloc((size_t)pw * (size_t)ph);
        d->values = malloc((size_t)nvalues * sizeof(float));
        d->deltas = malloc((size_t)ndeltas * sizeof(int64_t));
        d->plan = malloc((size_t)cols * sizeof *d->plan);
    }
    if (!d || !d->padded || !d->values || !d->deltas || !d->plan || !quad) {
        op_diffusion_end(d);
        free(quad);
        return op_error_set(err, OP_ERR_NOMEM, "diffusion: out of memory");
    }
    d->l = l;
    d->pw = pw;
    d->kernel = K;
    d->cols = cols;
    for (int y = 0; y < ph; y++)
        for (int x = 0; x < pw; x++)
            d->padded[(size_t)y * pw + x] = (uint8_t)op_layout_at(l, x - h, y - h);

    /* The table of every value an entry can take. */
    double eta = op_layout_eta(l, 0);
    if (eta != op_layout_eta(l, 1))
        op_log(OP_LOG_WARN, "diffusion: %s (index %.3g) and %s (%.3g) differ in index; a dipole "
               "has no interface between them to refract at, so the whole sample takes the "
               "base medium's %.3g (--eta sets another; montecarlo refracts at the interfaces)",
               l->media[0]->name, eta, l->media[1]->name, op_layout_eta(l, 1), eta);
    float *v = d->values;
    for (int ay = 0; ay <= h; ay++)
        for (int ax = 0; ax <= h; ax++) {
            int m = (ax > ay ? ax : ay) + 1;
            quad[ay * (h + 1) + ax] = v;
            int n = m <= 3 ? 10 : 4; /* more quadrature where Rd varies within a pixel */
            for (int k = 0; k <= m; k++) {
                double f = (double)k / m;
                for (int c = 0; c < 3; c++) {
                    double ss = (1 - f) * l->media[0]->sigma_s[c] + f * l->media[1]->sigma_s[c];
                    double sa = (1 - f) * l->media[0]->sigma_a[c] + f * l->media[1]->sigma_a[c];
                    op_dipole dp;
                    op_dipole_init(&dp, ss, sa, eta);
                    *v++ = (float)op_dipole_pixel(&dp, ax * l->pixel_x, ay * l->pixel_y,
                                                  l->pixel_x, l->pixel_y, n);
                }
            }
        }
    /* The sample points of each offset: point s of m lies at s * d / (m - 1) from the pixel
     * centre, in the pixel floor((2 s d + m - 1) / (2 (m - 1))) away. Integer arithmetic makes
     * the set of pixels the same from either end of the segment. */
    int64_t nd = 0;
    for (int o = 0; o < cols; o++) {
        int dx = o % K - h, dy = o / K - h, ax = abs(dx), ay = abs(dy);
        int m = (ax > ay ? ax : ay) + 1;
        d->plan[o] = (offset_plan){dx, dy, o, (int)nd, m, quad[ay * (h + 1) + ax]};
        for (int s = 0; s < m; s++) {
            int64_t sx = 0, sy = 0;
            if (m > 1) {
                sx = floor_div(2LL * s * dx + (m - 1), 2LL * (m - 1));
                sy = floor_div(2LL * s * dy + (m - 1), 2LL * (m - 1));
            }
            d->deltas[nd++] = sy * pw + sx;
        }
    }
    free(quad);
    *out = d;
    return OP_OK;
}

op_status op_diffusion_fill(const op_diffusion *d, int threads, op_progress *progress,
                            op_dataset *block, op_error *err)
{
    if (block->width != d->l->width || block->height != d->l->height || block->kernel != d->kernel)
        return op_error_set(err, OP_ERR_INTERNAL, "diffusion: dataset and layout disagree");
    if (block->nrows == 0)
        return OP_OK;
    /* Four tasks per thread: balanced, and the values do not depend on the split. */
    uint64_t nt = (uint64_t)op_parallel_threads(threads) * 4;
    uint64_t chunk = (block->nrows + nt - 1) / nt;
    diffusion_job job = {.d = d, .out = block, .chunk = chunk, .progress = progress};
    return op_parallel_for(threads, (int)((block->nrows + chunk - 1) / chunk), diffusion_rows,
                           &job, NULL, err);
}
