/* dipole_profile.c - the classical dipole profile and the named media (see dipole_profile.h).
 * The formulas are those of docs/subsurface-rendering.md. */
#include "sss/dipole_profile.h"

#include "opaline.h"

#include <math.h>

/* The named media are libopaline's one media table (op_medium_lookup), shared with the dataset
 * generator, so that a "Marble" here is the "Marble" of a dataset. */
int op_sss_dipole_lookup(const char *name, double sigma_sp_mm[3], double sigma_a_mm[3], double *eta)
{
    const op_medium *m = op_medium_lookup(name);
    if (!m)
        return 0;
    for (int c = 0; c < 3; c++) {
        sigma_sp_mm[c] = m->sigma_s[c];
        sigma_a_mm[c] = m->sigma_a[c];
    }
    *eta = m->eta;
    return 1;
}

const char *op_sss_dipole_names(void)
{
    return op_medium_names();
}

/* The quantities of one channel: reduced albedo, effective transport coefficient and the depths
 * of the real and virtual sources. */
typedef struct dip_ch {
    double alpha, sigma_tr, zr, zv;
} dip_ch;

static dip_ch channel(const op_sss_dipole *d, int c)
{
    dip_ch k;
    double st = d->sigma_a[c] + d->sigma_sp[c], eta = d->eta;
    double fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    double A = (1.0 + fdr) / (1.0 - fdr);
    k.alpha = st > 0.0 ? d->sigma_sp[c] / st : 0.0;
    k.sigma_tr = sqrt(3.0 * d->sigma_a[c] * st);
    k.zr = st > 0.0 ? 1.0 / st : 0.0;
    k.zv = k.zr * (1.0 + 4.0 * A / 3.0);
    return k;
}

double op_sss_dipole_rd(const op_sss_dipole *d, int c, double r)
{
    dip_ch k = channel(d, c);
    if (!(k.zr > 0.0))
        return 0.0;
    double dr = sqrt(r * r + k.zr * k.zr), dv = sqrt(r * r + k.zv * k.zv);
    double real = k.zr * (k.sigma_tr + 1.0 / dr) * exp(-k.sigma_tr * dr) / (dr * dr);
    double virt = k.zv * (k.sigma_tr + 1.0 / dv) * exp(-k.sigma_tr * dv) / (dv * dv);
    return k.alpha / (4.0 * M_PI) * (real + virt);
}

/* The integral of Rd over the disk of radius R: since d/dd (-e^(-s d)/d) = (s + 1/d) e^(-s d)/d^2
 * and r dr = d dd, each source contributes (alpha/2) (e^(-s z) - z e^(-s d(R))/d(R)). */
static double rd_within(dip_ch k, double R)
{
    double dr = sqrt(R * R + k.zr * k.zr), dv = sqrt(R * R + k.zv * k.zv);
    return 0.5 * k.alpha * (exp(-k.sigma_tr * k.zr) - k.zr * exp(-k.sigma_tr * dr) / dr +
                            exp(-k.sigma_tr * k.zv) - k.zv * exp(-k.sigma_tr * dv) / dv);
}

double op_sss_dipole_within(const op_sss_dipole *d, int c, double R)
{
    dip_ch k = channel(d, c);
    return k.zr > 0.0 ? rd_within(k, R) : 0.0;
}

/* With phi(x) = (s + 1/x) e^(-s x)/x^2, each source adds z phi(d), d = sqrt(r^2 + z^2):
 * phi' = -e^(-s x) (s^2/x^2 + 3 s/x^3 + 3/x^4), phi'' = e^(-s x) (s^3/x^2 + 5 s^2/x^3 +
 * 12 s/x^4 + 12/x^5), d' = r/d, d'' = z^2/d^3. */
void op_sss_dipole_rd_derivs(const op_sss_dipole *d, int c, double r, double f[3])
{
    dip_ch k = channel(d, c);
    f[0] = f[1] = f[2] = 0.0;
    if (!(k.zr > 0.0))
        return;
    const double z[2] = {k.zr, k.zv}, s = k.sigma_tr;
    for (int i = 0; i < 2; i++) {
        double x = sqrt(r * r + z[i] * z[i]), ix = 1.0 / x, e = exp(-s * x);
        double ix2 = ix * ix, ix3 = ix2 * ix, ix4 = ix2 * ix2;
        double phi = (s + ix) * e * ix2;
        double d1 = -e * (s * s * ix2 + 3.0 * s * ix3 + 3.0 * ix4);
        double d2 = e * (s * s * s * ix2 + 5.0 * s * s * ix3 + 12.0 * s * ix4 + 12.0 * ix4 * ix);
        f[0] += z[i] * phi;
        f[1] += z[i] * d1 * r * ix;
        f[2] += z[i] * (d2 * r * r * ix2 + d1 * z[i] * z[i] * ix3);
    }
    for (int i = 0; i < 3; i++)
        f[i] *= k.alpha / (4.0 * M_PI);
}

double op_sss_dipole_length(const op_sss_dipole *d, int c)
{
    dip_ch k = channel(d, c);
    return k.sigma_tr > 0.0 ? 1.0 / k.sigma_tr : INFINITY;
}

double op_sss_dipole_total(const op_sss_dipole *d, int c)
{
    dip_ch k = channel(d, c);
    if (!(k.zr > 0.0))
        return 0.0;
    return 0.5 * k.alpha * (exp(-k.sigma_tr * k.zr) + exp(-k.sigma_tr * k.zv));
}

double op_sss_dipole_radius(const op_sss_dipole *d, double loss)
{
    double R = 0.0;
    for (int c = 0; c < 3; c++) {
        dip_ch k = channel(d, c);
        double total = op_sss_dipole_total(d, c);
        if (!(total > 0.0))
            continue;
        double lo = 0.0, hi = k.zv > 0.0 ? k.zv : 1.0;
        while (rd_within(k, hi) < (1.0 - loss) * total && hi < 1e12 * k.zv)
            hi *= 2.0;
        for (int it = 0; it < 100; it++) {
            double mid = 0.5 * (lo + hi);
            if (rd_within(k, mid) < (1.0 - loss) * total)
                lo = mid;
            else
                hi = mid;
        }
        if (hi > R)
            R = hi;
    }
    return R;
}
