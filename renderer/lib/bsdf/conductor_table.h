/* conductor_table.h - Mitsuba 0.6's named conductors ("Cu", "Au", "Cu_palik", ...) as linear
 * sRGB complex indices of refraction (conductor_table.c, generated from Mitsuba's measured
 * spectra by scripts/conductor_table.py). "none" is not in the table: it names no material (a
 * perfect mirror), which the BSDFs treat themselves. */
#ifndef OP_CONDUCTOR_TABLE_H
#define OP_CONDUCTOR_TABLE_H

typedef struct op_conductor {
    const char *name;
    float eta[3], k[3]; /* relative to vacuum */
} op_conductor;

/* The conductor of that name (case-insensitive), or NULL. */
const op_conductor *op_conductor_find(const char *name);
/* The table's size, and its i-th entry (NULL outside [0, count)). */
int op_conductor_count(void);
const op_conductor *op_conductor_at(int i);

#endif
