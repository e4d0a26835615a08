/* media.h - the named scattering media opaline's synthetic datasets are made of.
 *
 * Coefficients are the reduced scattering sigma_s' and absorption sigma_a per R, G, B channel in
 * 1/mm (phase function g = 0 after reduction), as in Jensen et al. 2001's table. All media share
 * one relative refractive index (OP_MEDIUM_ETA = 1.3) because the sample has one flat boundary.
 */
#ifndef OP_FACTOR_MEDIA_H
#define OP_FACTOR_MEDIA_H

#define OP_MEDIUM_ETA 1.3

typedef struct op_medium {
    const char *name;      /* canonical spelling, e.g. "Marble" */
    double sigma_s[3];     /* reduced scattering coefficient, 1/mm */
    double sigma_a[3];     /* absorption coefficient, 1/mm */
    const char *source;    /* where the values come from */
} op_medium;

/* The medium called `name` (case-insensitive), or NULL when there is none. */
const op_medium *op_medium_find(const char *name);
/* The i-th medium of the table (0 <= i < op_medium_count()). */
const op_medium *op_medium_at(int i);
int op_medium_count(void);

#endif
