/* sky.h - Mitsuba 0.6's `sky` emitter: Hosek and Wilkie's clear-sky model (their linear sRGB
 * tables, as Mitsuba's RGB build uses them) for a sun placed by sunDirection or by the date,
 * time and place (Blanco-Muriel et al.'s PSA algorithm, "Computing the Solar Vector", Solar
 * Energy 70(5), 2001), tabulated at load time into a lat-long environment map as Mitsuba does.
 *
 * Sky coordinates are Mitsuba's: a direction of zenith angle theta and azimuth phi is
 * (sin theta sin phi, cos theta, -sin theta cos phi) in the emitter's space (+Y up, the sun's
 * azimuth measured from -Z towards +X, east), which toWorld places. */
#ifndef OP_SKY_H
#define OP_SKY_H

#include "opaline.h"
#include "opaline_image.h"
#include "math/transform.h"
#include "scene/scene_desc.h"

#define OP_HOSEK_COEFS (2 * 10 * 6 * 9)
#define OP_HOSEK_RADIANCES (2 * 10 * 6)
extern const double op_hosek_rgb[3][OP_HOSEK_COEFS];
extern const double op_hosek_rgb_radiance[3][OP_HOSEK_RADIANCES];

typedef struct op_sky_model {
    double coef[3][9];   /* per channel, the model's A..I for this sun, turbidity and albedo */
    double radiance[3];  /* per channel, the radiance scale */
    double sun_theta, sun_phi;
    double stretch;      /* zenith angles are divided by it (1 to 2: the sky reaches below the
                            horizon) */
    double scale;
    int extend;          /* Mitsuba's `extend`: below the horizon, the horizon's radiance
                            fading out */
} op_sky_model;

/* The model for turbidity in [1, 10], a ground albedo in [0, 1] per channel and the sun at
 * zenith angle sun_theta (at most pi/2) and azimuth sun_phi; stretch 1, scale 1, no extend. */
void op_sky_model_init(op_sky_model *m, double turbidity, const double albedo[3],
                       double sun_theta, double sun_phi);
/* Linear RGB radiance of the sky in the direction of zenith angle theta and azimuth phi. */
void op_sky_radiance(const op_sky_model *m, double theta, double phi, double rgb[3]);
/* The sun's zenith angle and azimuth in sky coordinates at local time hour:minute:second on
 * year-month-day, seen from latitude and longitude (degrees, north and east positive) in a
 * time zone `timezone` hours ahead of UTC. */
void op_sun_position(int year, int month, int day, double hour, double minute, double second,
                     double latitude, double longitude, double timezone, double *theta,
                     double *phi);
/* Reads an <emitter type="sky"> (xf its toWorld) into *m and tabulates it into img: `resolution`
 * x resolution / 2 RGB pixels, each the radiance at its centre, refused beyond max_pixels. */
op_status op_sky_build(op_node *node, const op_matrix4 *xf, long long max_pixels,
                       op_sky_model *m, op_image *img, op_error *err);

#endif
