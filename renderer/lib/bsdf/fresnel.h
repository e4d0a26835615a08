/* fresnel.h - the Fresnel reflectance of a smooth dielectric interface, the one formula every
 * dielectric model (bsdf.c, principled.c) uses. */
#ifndef OP_FRESNEL_H
#define OP_FRESNEL_H

/* The unpolarized Fresnel reflectance of a dielectric of relative index eta (inside over
 * outside) for cos_i (> 0 on the outside, the side of the normal); *cos_t gets the cosine of
 * the refracted direction (0 on total internal reflection, where it returns 1). */
float op_fresnel_dielectric(float cos_i, float eta, float *cos_t);
/* The same reflectance for a refraction whose two cosines are known: cos_out on the outside,
 * cos_in on the inside (magnitudes). The same value whichever way light crosses, and accurate
 * near total internal reflection, where cos_out is small and op_fresnel_dielectric, deriving it
 * from the inside's cosine, keeps none of its digits. */
float op_fresnel_dielectric_pair(float cos_out, float cos_in, float eta);

#endif
