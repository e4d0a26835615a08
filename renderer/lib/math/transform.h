/* transform.h - 4x4 affine transforms as Mitsuba builds them: row-major matrices acting on
 * column vectors (p' = M p). Composition M = A * B applies B first. */
#ifndef OP_TRANSFORM_H
#define OP_TRANSFORM_H

/* Row-major 4x4 matrix acting on column vectors: p' = M p. */
typedef struct op_matrix4 {
    double m[4][4];
} op_matrix4;

op_matrix4 op_matrix4_identity(void);
/* a * b: the transform that applies b, then a. */
op_matrix4 op_matrix4_mul(const op_matrix4 *a, const op_matrix4 *b);
op_matrix4 op_matrix4_transpose(const op_matrix4 *a);
op_matrix4 op_matrix4_translate(double x, double y, double z);
op_matrix4 op_matrix4_scale(double x, double y, double z);
/* Right-handed rotation by angle_deg degrees about axis (normalized here; a zero axis gives
 * the identity). */
op_matrix4 op_matrix4_rotate(const double axis[3], double angle_deg);
/* The camera-to-world matrix of Mitsuba's lookAt: columns left = normalize(up x dir),
 * up' = dir x left, dir = normalize(target - origin), origin. With up NULL an up perpendicular
 * to dir is chosen as Mitsuba's coordinateSystem() does. Returns 0 (and leaves *out the
 * identity) when target == origin, or up is zero or parallel to the viewing direction (within
 * 1e-9 radians: rounding would otherwise pick the frame). */
int op_matrix4_lookat(const double origin[3], const double target[3], const double up[3],
                      op_matrix4 *out);
/* General inverse by Gauss-Jordan elimination with partial pivoting. Returns 0 (and leaves
 * *out the identity) when a is singular or not finite. */
int op_matrix4_inverse(const op_matrix4 *a, op_matrix4 *out);
/* Whether every entry is finite. */
int op_matrix4_is_finite(const op_matrix4 *a);

/* Applying: a point (w = 1, divided by the projective row when it is not 0 0 0 1), a vector
 * (w = 0), and a normal, which needs the INVERSE matrix inv and uses its transpose. The
 * outputs may alias the inputs. */
void op_matrix4_point(const op_matrix4 *a, const double p[3], double out[3]);
void op_matrix4_vector(const op_matrix4 *a, const double v[3], double out[3]);
void op_matrix4_normal(const op_matrix4 *inv, const double n[3], double out[3]);

#endif
