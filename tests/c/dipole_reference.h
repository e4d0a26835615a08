/* dipole_reference.h - the classical dipole of Jensen et al. 2001, written in the tests from the
 * paper's formulas, independently of renderer/lib/sss/dipole_profile.c, as the reference the
 * dipole tests compare the renderer with. Coefficients per mm (reduced scattering sp,
 * absorption sa), relative index of refraction eta, distances in mm. */
#ifndef OP_TEST_DIPOLE_REFERENCE_H
#define OP_TEST_DIPOLE_REFERENCE_H

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* The internal-reflection parameter A of the boundary condition (Groenhuis' fit of F_dr). */
static inline double ref_dipole_a(double eta)
{
    double fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    return (1.0 + fdr) / (1.0 - fdr);
}

/* The diffuse reflectance profile Rd(r), per mm^2. */
static inline double ref_dipole_rd(double sp, double sa, double eta, double r)
{
    double st = sa + sp, alpha = sp / st, str = sqrt(3.0 * sa * st);
    double zr = 1.0 / st, zv = zr * (1.0 + 4.0 * ref_dipole_a(eta) / 3.0);
    double dr = sqrt(r * r + zr * zr), dv = sqrt(r * r + zv * zv);
    return alpha / (4.0 * M_PI) *
           (zr * (str + 1.0 / dr) * exp(-str * dr) / (dr * dr) +
            zv * (str + 1.0 / dv) * exp(-str * dv) / (dv * dv));
}

/* The total diffuse reflectance: the integral of Rd over the plane. */
static inline double ref_dipole_total(double sp, double sa, double eta)
{
    double alpha = sp / (sa + sp), s = sqrt(3.0 * (1.0 - alpha));
    return 0.5 * alpha * (1.0 + exp(-4.0 / 3.0 * ref_dipole_a(eta) * s)) * exp(-s);
}

/* The exitance at distance x from the centre of a disk of radius a lit by a point light of
 * intensity D^2 at height D (irradiance D^3 / (D^2 + rho^2)^1.5, 1 at the centre): the profile
 * integrated over the disk (midpoint rule in polar coordinates about the disk's centre). */
static inline double ref_dipole_spot(double sp, double sa, double eta, double a, double D,
                                     double x)
{
    const int nr = 240, nphi = 240;
    double sum = 0.0;
    for (int i = 0; i < nr; i++) {
        double rho = a * (i + 0.5) / nr, e = D * D * D / pow(D * D + rho * rho, 1.5);
        for (int j = 0; j < nphi; j++) {
            double phi = M_PI * (j + 0.5) / nphi; /* symmetric: half the circle, twice */
            double d2 = x * x + rho * rho - 2.0 * x * rho * cos(phi);
            sum += e * ref_dipole_rd(sp, sa, eta, sqrt(d2 > 0.0 ? d2 : 0.0)) * rho;
        }
    }
    return sum * 2.0 * (a / nr) * (M_PI / nphi);
}

#endif
