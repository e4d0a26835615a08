/* dipole_kernel.c - the dipole as the hierarchical sum's profile (see dipole_kernel.h). */
#include "sss/dipole_kernel.h"

#include <stdlib.h>
#include <string.h>

/* The medium with every channel equal to channel c of d. */
static op_sss_dipole one_channel(const op_sss_dipole *d, int c)
{
    op_sss_dipole e = *d;
    for (int q = 0; q < 3; q++) {
        e.sigma_a[q] = d->sigma_a[c];
        e.sigma_sp[q] = d->sigma_sp[c];
    }
    return e;
}

static double channel_radius(const op_sss_dipole *d, int c, double loss)
{
    op_sss_dipole e = one_channel(d, c);
    return op_sss_dipole_radius(&e, loss);
}

double op_sss_dipole_spacing(const op_sss_dipole *d)
{
    double l = INFINITY;
    for (int c = 0; c < 3; c++)
        l = fmin(l, fmin(op_sss_dipole_length(d, c), channel_radius(d, c, 1e-3) / 8.0));
    return l / 6.0;
}

/* Rd of channel c averaged over the disk of radius rho whose centre lies r away: the part of
 * the disk within |rho - r| of the point of exit in closed form, the rest over the arcs of the
 * circles around it that cross the disk (midpoint rule). */
static double disk_average(const op_sss_dipole *d, int c, double rho, double r)
{
    enum { N = 1024 };
    double inner = r < rho ? op_sss_dipole_within(d, c, rho - r) : 0.0;
    double s0 = fabs(rho - r), s1 = rho + r, ds = (s1 - s0) / N, sum = 0.0;
    if (r > 0.0)
        for (int i = 0; i < N; i++) {
            double s = s0 + (i + 0.5) * ds;
            double cosv = (s * s + r * r - rho * rho) / (2.0 * s * r);
            cosv = cosv < -1.0 ? -1.0 : cosv > 1.0 ? 1.0 : cosv;
            double f[3];
            op_sss_dipole_rd_derivs(d, c, s, f);
            sum += f[0] * 2.0 * s * acos(cosv) * ds;
        }
    return (inner + sum) / (M_PI * rho * rho);
}

/* From the far table (linear in log r), or the closed form outside it. */
static void far_profile(const void *user, int c, double r, double f[3])
{
    const op_sss_dipole_kernel *k = user;
    double x = r > k->far0 ? log(r / k->far0) * k->far_scale : -1.0;
    if (x >= 0.0 && x < (double)(k->nfar - 1)) {
        int i = (int)x;
        double t = x - i;
        const float *a = k->far + (size_t)9 * i + 3 * c, *b = a + 9;
        for (int q = 0; q < 3; q++)
            f[q] = a[q] + t * (b[q] - a[q]);
        return;
    }
    op_sss_dipole_rd_derivs(&k->d, c, r, f);
}

static void near_profile(const void *user, float r, float out[3])
{
    const op_sss_dipole_kernel *k = user;
    float x = r / k->step;
    if (x < (float)(k->ntab - 1)) {
        int i = (int)x;
        float t = x - (float)i;
        const float *a = k->tab + 3 * (size_t)i;
        for (int c = 0; c < 3; c++)
            out[c] = a[c] + t * (a[3 + c] - a[c]);
        return;
    }
    for (int c = 0; c < 3; c++) {
        double f[3];
        far_profile(k, c, r, f);
        out[c] = (float)f[0];
    }
}

op_status op_sss_dipole_kernel_init(op_sss_dipole_kernel *k, const op_sss_dipole *d,
                                    double area, double spacing, op_error *err)
{
    memset(k, 0, sizeof *k);
    k->d = *d;
    /* the disk average differs from Rd by about rho^2/8 x its Laplacian: tabulated to 12 disk
     * radii (about 1 % there for Rd ~ 1/r^3), 24 steps per radius */
    double rho = sqrt(area / M_PI);
    k->ntab = 12 * 24 + 2;
    k->step = (float)(rho / 24.0);
    k->tab = malloc(3 * (size_t)k->ntab * sizeof *k->tab);
    if (!k->tab)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the dipole's profile");
    for (int i = 0; i < k->ntab; i++)
        for (int c = 0; c < 3; c++)
            k->tab[3 * i + c] = (float)disk_average(d, c, rho, i * (double)k->step);
    op_sss_radial *q = &k->radial;
    q->exact = (float)(6.0 * spacing);
    q->reach = 0.0f;
    for (int c = 0; c < 3; c++)
        q->reach = fmaxf(q->reach, (float)channel_radius(d, c, 1e-5));
    /* aggregates are evaluated from the exact distance on: 256 entries per factor e of r
     * (a linear interpolation error below 1e-4 for profiles falling by e over 8 % of r) */
    k->far0 = 0.5 * q->exact;
    k->far_scale = 256.0;
    k->nfar = (int)ceil(log(fmax(2.0 * q->reach / k->far0, 2.0)) * k->far_scale) + 2;
    k->far = malloc((size_t)9 * k->nfar * sizeof *k->far);
    if (!k->far)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory for the dipole's profile");
    for (int i = 0; i < k->nfar; i++)
        for (int c = 0; c < 3; c++) {
            double f[3];
            op_sss_dipole_rd_derivs(d, c, k->far0 * exp(i / k->far_scale), f);
            for (int j = 0; j < 3; j++)
                k->far[(size_t)9 * i + 3 * c + j] = (float)f[j];
        }
    /* the near profile's integral over the disk of 6 spacings (trapezoid on the table) */
    q->ball = q->exact;
    for (int c = 0; c < 3; c++) {
        double sum = 0.0;
        for (int i = 0; i + 1 < k->ntab && (i + 1) * (double)k->step <= q->ball; i++) {
            double r0 = i * (double)k->step, r1 = r0 + k->step;
            sum += 0.5 * (k->tab[3 * i + c] * r0 + k->tab[3 * (i + 1) + c] * r1) * k->step;
        }
        q->ball_total[c] = (float)(2.0 * M_PI * sum);
    }
    q->near = near_profile;
    q->far = far_profile;
    q->user = k;
    q->theta = 0.35f;
    for (int c = 0; c < 3; c++) {
        /* a cluster of radius up to 0.75 diffusion lengths keeps the third- and fourth-order
         * terms the expansion drops within about 1 %; beyond the 0.01 % radius the channel's
         * share is too small for its relative error to matter */
        q->size[c] = (float)(0.75 * op_sss_dipole_length(d, c));
        q->fade[c] = (float)channel_radius(d, c, 1e-4);
    }
    return OP_OK;
}

void op_sss_dipole_kernel_free(op_sss_dipole_kernel *k)
{
    free(k->tab);
    free(k->far);
    k->tab = NULL;
    k->far = NULL;
}
