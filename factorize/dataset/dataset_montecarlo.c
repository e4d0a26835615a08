/* dataset_montecarlo.c - photon transport through the heterogeneous semi-infinite slab. */
#include "dataset_montecarlo.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------ random numbers */

typedef struct rng {
    uint64_t s[4];
} rng;

/* The stream of one (channel, pixel) work unit. */
static void rng_seed(rng *r, uint64_t seed, uint64_t channel, uint64_t pixel)
{
    uint64_t x = seed;
    x = op_splitmix64(&x) ^ (channel * 0xd1b54a32d192ed03ULL);
    x = op_splitmix64(&x) ^ pixel;
    for (int i = 0; i < 4; i++)
        r->s[i] = op_splitmix64(&x);
}

static inline uint64_t rotl(uint64_t x, int k)
{
    return (x << k) | (x >> (64 - k));
}

/* Uniform in [0, 1), 53 bits. */
static inline double rng_uniform(rng *r)
{
    uint64_t *s = r->s;
    uint64_t result = s[0] + s[3];
    uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return (double)(result >> 11) * 0x1.0p-53;
}

/* ------------------------------------------------------------ transport */

/* Unpolarized Fresnel reflectance for light in index n1 meeting index n2 with cosine
 * cos_i > 0 (1 under total internal reflection). */
static double fresnel(double cos_i, double n1, double n2)
{
    double r = n1 / n2, sin_t2 = r * r * (1 - cos_i * cos_i);
    if (sin_t2 >= 1)
        return 1;
    double cos_t = sqrt(1 - sin_t2);
    double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    double rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    return 0.5 * (rs * rs + rp * rp);
}

typedef struct mc_job {
    const op_layout *l;
    const op_mc_options *o;
    op_dataset *out;
    struct mc_thread *threads; /* per worker thread of op_parallel_for */
    uint64_t units;
    double *total;      /* per unit: all escaping weight / photons */
    double *rowsum;     /* per unit: row sum */
    double *rowse;      /* per unit: standard error of the row sum */
} mc_job;

typedef struct mc_thread {
    mc_job *job;
    uint64_t steps, lost;
    double *sum, *sq;   /* K*K tallies of the unit in progress */
} mc_thread;

/* The medium (0 or 1) of the pixel under the point at (u, v) sample widths, in the periodic
 * tiling, without integer division. */
static inline int medium_at(const op_layout *l, double u, double v)
{
    int ix = (int)((u - floor(u)) * l->width), iy = (int)((v - floor(v)) * l->height);
    ix = ix < l->width ? ix : l->width - 1;
    iy = iy < l->height ? iy : l->height - 1;
    return l->map[iy * l->width + ix];
}

/* A photon: position (mm) and direction; in a sample whose two media differ in index also the
 * pixel it is in, (cx, cy) unwrapped (floor(x / pixel_x), floor(y / pixel_y) while x, y lie
 * inside a pixel; kept by the flight on a pixel's side, where rounding could not tell), the
 * same pixel wrapped into the map, (wx, wy), and its medium m. */
typedef struct photon {
    double x, y, z, ux, uy, uz;
    int64_t cx, cy;
    int wx, wy, m;
} photon;

typedef enum flight { FLIGHT_COLLISION, FLIGHT_SURFACE, FLIGHT_INTERFACE } flight;

/* Moves p along its direction for the free path s through the pixel columns: to a tentative
 * collision (FLIGHT_COLLISION), to the surface z = 0 (FLIGHT_SURFACE), or to the first side of
 * a pixel where the medium changes (FLIGHT_INTERFACE), where p is reflected (Fresnel, total
 * internal reflection included) or refracted (Snell) into the next pixel; the caller then draws
 * a new free path (the majorant's free paths are memoryless). */
static flight fly(photon *p, double s, const op_layout *l, const double eta_m[2], rng *r)
{
    for (;;) {
        double bx = (double)(p->ux > 0 ? p->cx + 1 : p->cx) * l->pixel_x;
        double by = (double)(p->uy > 0 ? p->cy + 1 : p->cy) * l->pixel_y;
        /* Distances to the sides ahead and the surface, each along its own axis (rounding may
         * leave the photon a hair past a side: 0). Most flights end inside the pixel, found
         * without dividing. */
        double dx = p->ux > 0 ? bx - p->x : p->x - bx, dy = p->uy > 0 ? by - p->y : p->y - by;
        double ax = fabs(p->ux), ay = fabs(p->uy), az = -p->uz;
        dx = dx > 0 ? dx : 0;
        dy = dy > 0 ? dy : 0;
        int reach_x = ax > 0 && s * ax >= dx, reach_y = ay > 0 && s * ay >= dy;
        int reach_surf = az > 0 && s * az >= p->z;
        if (!reach_x && !reach_y && !reach_surf) {
            p->x += p->ux * s;
            p->y += p->uy * s;
            p->z += p->uz * s;
            return FLIGHT_COLLISION;
        }
        double tx = reach_x ? dx / ax : INFINITY, ty = reach_y ? dy / ay : INFINITY;
        double t_surf = reach_surf ? (p->z > 0 ? p->z / az : 0) : INFINITY;
        double t_side = tx <= ty ? tx : ty;
        if (t_surf <= t_side) {
            p->x += p->ux * t_surf;
            p->y += p->uy * t_surf;
            p->z = 0;
            return FLIGHT_SURFACE;
        }
        int along_x = tx <= ty;
        p->x = along_x ? bx : p->x + p->ux * t_side;
        p->y = along_x ? p->y + p->uy * t_side : by;
        p->z += p->uz * t_side;
        s = s > t_side ? s - t_side : 0;
        int step = (along_x ? p->ux : p->uy) > 0 ? 1 : -1;
        int wx = p->wx, wy = p->wy;
        if (along_x)
            wx = wx + step == l->width ? 0 : wx + step < 0 ? l->width - 1 : wx + step;
        else
            wy = wy + step == l->height ? 0 : wy + step < 0 ? l->height - 1 : wy + step;
        int mn = l->map[wy * l->width + wx];
        if (mn == p->m) {
            p->cx += along_x ? step : 0;
            p->cy += along_x ? 0 : step;
            p->wx = wx;
            p->wy = wy;
            continue;
        }
        double *normal = along_x ? &p->ux : &p->uy;
        double n1 = eta_m[p->m], n2 = eta_m[mn];
        if (rng_uniform(r) < fresnel(fabs(*normal), n1, n2)) {
            *normal = -*normal;
        } else {
            double q = n1 / n2, sign = *normal > 0 ? 1 : -1;
            p->ux *= q;
            p->uy *= q;
            p->uz *= q;
            double tangential = along_x ? p->uy * p->uy + p->uz * p->uz
                                        : p->ux * p->ux + p->uz * p->uz;
            *normal = sign * sqrt(fmax(0, 1 - tangential));
            p->cx += along_x ? step : 0;
            p->cy += along_x ? 0 : step;
            p->wx = wx;
            p->wy = wy;
            p->m = mn;
        }
        return FLIGHT_INTERFACE;
    }
}

/* Adds an escaping weight w to the tallies of exit offset (ex, ey) pixels, if in the kernel. */
static inline void tally_exit(mc_thread *t, double w, int64_t ex, int64_t ey, int K)
{
    int h = K / 2;
    if (ex >= -h && ex <= h && ey >= -h && ey <= h) {
        int col = (int)(ey + h) * K + (int)(ex + h);
        t->sum[col] += w;
        t->sq[col] += w * w;
    }
}

/* Traces every photon of channel c entering pixel (px, py); fills row and standard errors.
 * Where the two media have one index, the pixel sides are not interfaces and the flight is a
 * plain straight line. */
static void trace_unit(mc_thread *t, int c, int px, int py, uint64_t unit)
{
    mc_job *j = t->job;
    const op_layout *l = j->l;
    int K = j->out->kernel, cols = K * K;
    double sig_t[2], p_real[2], albedo[2];
    for (int m = 0; m < 2; m++) {
        sig_t[m] = l->media[m]->sigma_s[c] + l->media[m]->sigma_a[c];
        albedo[m] = sig_t[m] > 0 ? l->media[m]->sigma_s[c] / sig_t[m] : 0;
    }
    double sig_bar = fmax(sig_t[0], sig_t[1]);
    for (int m = 0; m < 2; m++)
        p_real[m] = sig_t[m] / sig_bar;
    int hetero = l->media[0] != l->media[1];
    double inv_hx = 1 / l->pixel_x, inv_hy = 1 / l->pixel_y, inv_bar = 1 / sig_bar;
    double inv_tx = 1 / (l->pixel_x * l->width), inv_ty = 1 / (l->pixel_y * l->height);
    const double eta_m[2] = {op_layout_eta(l, 0), op_layout_eta(l, 1)};
    const int one_eta = eta_m[0] == eta_m[1];
    const int diffuse = j->o->incidence == OP_MC_DIFFUSE;
    rng r;
    rng_seed(&r, j->o->seed, (uint64_t)c, (uint64_t)py * (uint64_t)l->width + (uint64_t)px);
    memset(t->sum, 0, (size_t)cols * sizeof(double));
    memset(t->sq, 0, (size_t)cols * sizeof(double));
    double total = 0;
    uint64_t steps = 0;
    uint64_t n = j->o->photons;
    for (uint64_t p = 0; p < n; p++) {
        photon ph = {.x = (px + rng_uniform(&r)) * l->pixel_x};
        ph.y = (py + rng_uniform(&r)) * l->pixel_y;
        ph.uz = 1;
        ph.cx = ph.wx = px;
        ph.cy = ph.wy = py;
        ph.m = l->map[py * l->width + px];
        double w = 1;
        /* The boundary's index where the photon crosses it: that of the medium there. */
        double eta = eta_m[one_eta ? 0 : ph.m];
        if (diffuse) {
            /* Cosine-weighted from outside, kept with the Fresnel transmittance, refracted. */
            double ct, phi;
            do {
                ct = sqrt(1 - rng_uniform(&r));
                phi = 2 * M_PI * rng_uniform(&r);
            } while (rng_uniform(&r) < fresnel(ct, 1.0, eta));
            double st = sqrt(1 - ct * ct) / eta;
            ph.ux = st * cos(phi);
            ph.uy = st * sin(phi);
            ph.uz = sqrt(1 - st * st);
        }
        uint64_t k;
        for (k = 0; k < OP_MC_MAX_STEPS; k++) {
            double s = -log(1 - rng_uniform(&r)) * inv_bar;
            int m = 0;
            if (one_eta) {
                double zn = ph.z + ph.uz * s;
                if (zn < 0) {
                    /* Reaches the surface: Fresnel reflection or exit; the free path restarts. */
                    double tt = -ph.z / ph.uz;
                    ph.x += ph.ux * tt;
                    ph.y += ph.uy * tt;
                    ph.z = 0;
                    if (rng_uniform(&r) < fresnel(-ph.uz, eta, 1.0)) {
                        ph.uz = -ph.uz;
                        continue;
                    }
                    total += w;
                    tally_exit(t, w, (int64_t)floor(ph.x * inv_hx) - px,
                               (int64_t)floor(ph.y * inv_hy) - py, K);
                    break;
                }
                ph.x += ph.ux * s;
                ph.y += ph.uy * s;
                ph.z = zn;
                if (hetero)
                    m = medium_at(l, ph.x * inv_tx, ph.y * inv_ty);
            } else {
                flight f = fly(&ph, s, l, eta_m, &r);
                if (f == FLIGHT_INTERFACE)
                    continue;
                m = ph.m;
                if (f == FLIGHT_SURFACE) {
                    /* As above, at the index of the pixel the photon reaches the surface in. */
                    if (rng_uniform(&r) < fresnel(-ph.uz, eta_m[m], 1.0)) {
                        ph.uz = -ph.uz;
                        continue;
                    }
                    total += w;
                    tally_exit(t, w, ph.cx - px, ph.cy - py, K);
                    break;
                }
            }
            if (hetero && rng_uniform(&r) >= p_real[m])
                continue; /* null collision */
            w *= albedo[m];
            if (w < 0.1) {
                if (rng_uniform(&r) * 0.5 >= w)
                    break; /* Russian roulette: absorbed */
                w = 0.5;
            }
            /* Isotropic direction (Marsaglia). */
            double a, b, q;
            do {
                a = 2 * rng_uniform(&r) - 1;
                b = 2 * rng_uniform(&r) - 1;
                q = a * a + b * b;
            } while (q >= 1);
            double f = 2 * sqrt(1 - q);
            ph.ux = a * f;
            ph.uy = b * f;
            ph.uz = 1 - 2 * q;
        }
        steps += k + 1;
        if (k == OP_MC_MAX_STEPS)
            t->lost++;
    }
    t->steps += steps;
    uint64_t row = (uint64_t)py * (uint64_t)l->width + (uint64_t)px - j->out->row0;
    float *rd = j->out->rd[c] + row * (uint64_t)cols, *se = j->out->se[c] + row * (uint64_t)cols;
    double dn = (double)n, rs = 0, rq = 0;
    for (int i = 0; i < cols; i++) {
        double mean = t->sum[i] / dn;
        double var = n > 1 ? fmax(0, (t->sq[i] - dn * mean * mean) / (dn - 1)) : mean * mean;
        rd[i] = (float)mean;
        se[i] = (float)sqrt(var / dn);
        rs += t->sum[i];
        rq += t->sq[i];
    }
    double mean = rs / dn;
    j->total[unit] = total / dn;
    j->rowsum[unit] = mean;
    j->rowse[unit] = sqrt((n > 1 ? fmax(0, (rq - dn * mean * mean) / (dn - 1)) : mean * mean) / dn);
}

/* Traces unit u: channel u / rows, row u % rows of the block (one op_parallel_for task). */
static void mc_task(void *user, int u, int thread)
{
    mc_job *j = user;
    uint64_t rows = j->out->nrows;
    int c = (int)((uint64_t)u / rows);
    uint64_t p = j->out->row0 + (uint64_t)u % rows;
    trace_unit(&j->threads[thread], c, (int)(p % (uint64_t)j->l->width),
               (int)(p / (uint64_t)j->l->width), (uint64_t)u);
    op_progress_advance(j->o->progress, 1);
}

op_status op_mc_generate(const op_layout *l, const op_mc_options *o, op_dataset *out,
                         op_mc_stats *stats, op_error *err)
{
    if (out->row0 == 0)
        memset(stats, 0, sizeof *stats);
    int K = out->kernel, cols = K * K;
    if (out->width != l->width || out->height != l->height || !out->se[0] || K < 1 || K % 2 == 0)
        return op_error_set(err, OP_ERR_INTERNAL, "montecarlo: dataset and layout disagree");
    if (o->photons < 1 || o->threads < 1)
        return op_error_set(err, OP_ERR_INPUT, "montecarlo: photons and threads must be >= 1");
    for (int m = 0; m < 2; m++)
        for (int c = 0; c < 3; c++)
            if (!(l->media[m]->sigma_s[c] + l->media[m]->sigma_a[c] > 0))
                return op_error_set(err, OP_ERR_INPUT, "medium %s has no extinction",
                                    l->media[m]->name);
    int threads = op_parallel_threads(o->threads);
    uint64_t pixels = (uint64_t)l->width * (uint64_t)l->height;
    if (3 * pixels > INT_MAX)
        return op_error_set(err, OP_ERR_INPUT, "montecarlo: %llu incident pixels are too many",
                            (unsigned long long)pixels);
    if (out->nrows == 0)
        return OP_OK;
    mc_job job = {.l = l, .o = o, .out = out, .units = 3 * out->nrows};
    job.total = malloc(job.units * sizeof(double));
    job.rowsum = malloc(job.units * sizeof(double));
    job.rowse = malloc(job.units * sizeof(double));
    mc_thread *th = calloc((size_t)threads, sizeof *th);
    double *tallies = malloc((size_t)threads * 2 * (size_t)cols * sizeof(double));
    if (!job.total || !job.rowsum || !job.rowse || !th || !tallies) {
        free(job.total), free(job.rowsum), free(job.rowse), free(th), free(tallies);
        return op_error_set(err, OP_ERR_NOMEM, "montecarlo: out of memory");
    }
    for (int t = 0; t < threads; t++) {
        th[t].job = &job;
        th[t].sum = tallies + (size_t)t * 2 * (size_t)cols;
        th[t].sq = th[t].sum + cols;
    }
    double t0 = op_monotonic_seconds();
    job.threads = th;
    op_status st = op_parallel_for(threads, (int)job.units, mc_task, &job, NULL, err);
    stats->seconds += op_monotonic_seconds() - t0;
    if (st != OP_OK) {
        free(job.total), free(job.rowsum), free(job.rowse), free(th), free(tallies);
        return st;
    }

    for (int t = 0; t < threads; t++) {
        stats->steps += th[t].steps;
        stats->lost += th[t].lost;
    }
    stats->photons += job.units * o->photons;
    stats->steps_per_second = stats->seconds > 0 ? (double)stats->steps / stats->seconds : 0;
    for (uint64_t u = 0; u < job.units; u++) {
        int c = (int)(u / out->nrows);
        stats->total_reflectance[c] += job.total[u] / (double)pixels;
        stats->mean_albedo[c] += job.rowsum[u] / (double)pixels;
        if (job.rowsum[u] > 0) {
            double q = job.rowse[u] / job.rowsum[u];
            stats->rel_se_sum += q;
            stats->rel_se_count++;
            if (q > stats->max_rel_se)
                stats->max_rel_se = q;
        }
    }
    stats->mean_rel_se =
        stats->rel_se_count ? stats->rel_se_sum / (double)stats->rel_se_count : 0;
    if (stats->lost && out->row0 + out->nrows == pixels)
        op_log(OP_LOG_WARN, "montecarlo: %llu photon(s) stopped after %u steps (counted absorbed)",
               (unsigned long long)stats->lost, OP_MC_MAX_STEPS);
    free(job.total), free(job.rowsum), free(job.rowse), free(th), free(tallies);
    return st;
}
