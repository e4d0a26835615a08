/* dipole_profile.h - the classical dipole diffusion profile of a homogeneous medium (Jensen,
 * Marschner, Levoy, Hanrahan 2001): the named media of that paper, the radial profile Rd(r) and
 * its integral over the plane, the total diffuse reflectance. Units: coefficients are per unit
 * length and r is in the same unit; Rd(r) is per unit area. docs/subsurface-rendering.md says
 * how scenes give the coefficients. */
#ifndef OP_SSS_DIPOLE_PROFILE_H
#define OP_SSS_DIPOLE_PROFILE_H

/* A homogeneous medium, per channel R, G, B. */
typedef struct op_sss_dipole {
    double sigma_a[3];  /* absorption */
    double sigma_sp[3]; /* reduced scattering sigma_s (1 - g) */
    double eta;         /* interior / exterior index of refraction, > 0 */
} op_sss_dipole;

/* The named medium of libopaline's media table (op_medium_lookup, case-insensitive: Jensen et
 * al. 2001's Apple ... Wholemilk, and the generator's Vein, dyes and blends): its reduced
 * scattering and absorption in 1/mm and its index of refraction (1.3; 1.5 for Marble and Vein).
 * Returns 0 when the name is unknown (the arrays are then untouched). */
int op_sss_dipole_lookup(const char *name, double sigma_sp_mm[3], double sigma_a_mm[3], double *eta);
/* The names, comma separated, for messages. */
const char *op_sss_dipole_names(void);

/* Rd(r) of channel c: the diffuse reflectance per unit area at distance r >= 0 from a point of
 * unit incident power. Finite and >= 0 for any medium with sigma_a + sigma_sp > 0. */
double op_sss_dipole_rd(const op_sss_dipole *d, int c, double r);
/* Rd(r) of channel c and its first and second derivatives in r, at r >= 0 (closed form):
 * f[0] = Rd, f[1] = dRd/dr, f[2] = d^2Rd/dr^2. */
void op_sss_dipole_rd_derivs(const op_sss_dipole *d, int c, double r, double f[3]);
/* The integral of Rd over the disk of radius R around the point of entry (closed form). */
double op_sss_dipole_within(const op_sss_dipole *d, int c, double R);
/* The diffusion length 1/sigma_tr of channel c (infinite without absorption). */
double op_sss_dipole_length(const op_sss_dipole *d, int c);
/* The integral of Rd over the plane (closed form), in [0, 1). */
double op_sss_dipole_total(const op_sss_dipole *d, int c);
/* The smallest radius within which the integral of Rd reaches (1 - loss) of the total, for
 * every channel (found numerically); loss in (0, 1). */
double op_sss_dipole_radius(const op_sss_dipole *d, double loss);

#endif
