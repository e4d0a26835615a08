/* sky.c - Hosek and Wilkie's sky and the sun's position (see sky.h). */
#include "light/sky.h"

#include <math.h>
#include <stdlib.h>

/* The value at s of the quintic Bezier curve whose control points are p[0], p[stride], ...
 * p[5 stride]. */
static double bezier5(const double *p, int stride, double s)
{
    static const double binom[6] = {1, 5, 10, 10, 5, 1};
    double v = 0.0;
    for (int k = 0; k < 6; k++)
        v += binom[k] * pow(1.0 - s, 5 - k) * pow(s, k) * p[k * stride];
    return v;
}

void op_sky_model_init(op_sky_model *m, double turbidity, const double albedo[3],
                       double sun_theta, double sun_phi)
{
    /* the tables interpolate over the cube root of the sun's elevation over pi/2, linearly
     * over turbidity (integers 1..10) and ground albedo (0 and 1) */
    double s = cbrt(fmax(0.0, (M_PI / 2.0 - sun_theta) / (M_PI / 2.0)));
    int t0 = (int)turbidity;
    t0 = t0 < 1 ? 1 : (t0 > 10 ? 10 : t0);
    double tf = turbidity - t0;
    for (int c = 0; c < 3; c++) {
        m->radiance[c] = 0.0;
        for (int i = 0; i < 9; i++)
            m->coef[c][i] = 0.0;
        for (int a = 0; a < 2; a++)
            for (int dt = 0; dt < 2 && t0 + dt <= 10; dt++) {
                double w = (a ? albedo[c] : 1.0 - albedo[c]) * (dt ? tf : 1.0 - tf);
                int t = t0 + dt - 1;
                const double *cp = op_hosek_rgb[c] + (a * 10 + t) * 54;
                for (int i = 0; i < 9; i++)
                    m->coef[c][i] += w * bezier5(cp + i, 9, s);
                m->radiance[c] += w * bezier5(op_hosek_rgb_radiance[c] + (a * 10 + t) * 6, 1, s);
            }
    }
    m->sun_theta = sun_theta;
    m->sun_phi = sun_phi;
    m->stretch = 1.0;
    m->scale = 1.0;
    m->extend = 0;
}

/* The model's distribution F(theta, gamma) (gamma the angle to the sun) of coefficients A..I. */
static double hosek_f(const double *k, double cos_theta, double gamma)
{
    double cg = cos(gamma);
    double mie = (1.0 + cg * cg) / pow(1.0 + k[8] * k[8] - 2.0 * k[8] * cg, 1.5);
    return (1.0 + k[0] * exp(k[1] / (cos_theta + 0.01))) *
           (k[2] + k[3] * exp(k[4] * gamma) + k[5] * cg * cg + k[6] * mie +
            k[7] * sqrt(cos_theta));
}

void op_sky_radiance(const op_sky_model *m, double theta, double phi, double rgb[3])
{
    double t = theta / m->stretch;
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    if (cos(t) <= 0.0) {
        if (!m->extend)
            return;
        t = 0.5 * M_PI - 1e-4;
    }
    double cos_gamma = cos(t) * cos(m->sun_theta) +
                       sin(t) * sin(m->sun_theta) * cos(phi - m->sun_phi);
    double gamma = acos(fmax(-1.0, fmin(1.0, cos_gamma)));
    double fade = 1.0;
    if (m->extend) { /* smoothstep from the horizon (1) to straight down (0) */
        double x = fmax(0.0, fmin(1.0, 2.0 - 2.0 * theta / M_PI));
        fade = x * x * (3.0 - 2.0 * x);
    }
    for (int c = 0; c < 3; c++) {
        /* 106.856980 is the sum of the CIE Y table over Mitsuba's wavelengths: the RGB tables'
         * normalization in Mitsuba's RGB build */
        double v = hosek_f(m->coef[c], cos(t), gamma) * m->radiance[c] / 106.856980;
        rgb[c] = fmax(v, 0.0) * fade * m->scale;
    }
}

void op_sun_position(int year, int month, int day, double hour, double minute, double second,
                     double latitude, double longitude, double timezone, double *theta,
                     double *phi)
{
    /* days since JD 2451545.0 (noon, 1 January 2000, UT), by the integer Julian day formula */
    double ut = hour - timezone + (minute + second / 60.0) / 60.0;
    int a = (month - 14) / 12;
    long jdn = (1461L * (year + 4800 + a)) / 4 + (367L * (month - 2 - 12 * a)) / 12 -
               (3L * ((year + 4900 + a) / 100)) / 4 + day - 32075;
    double n = (double)jdn - 0.5 + ut / 24.0 - 2451545.0;
    /* ecliptic coordinates (radians) */
    double omega = 2.1429 - 0.0010394594 * n;
    double mean_lon = 4.8950630 + 0.017202791698 * n;
    double anomaly = 6.2400600 + 0.0172019699 * n;
    double ecl_lon = mean_lon + 0.03341607 * sin(anomaly) + 0.00034894 * sin(2.0 * anomaly) -
                     0.0001134 - 0.0000203 * sin(omega);
    double obliquity = 0.4090928 - 6.2140e-9 * n + 0.0000396 * cos(omega);
    /* celestial coordinates */
    double ra = atan2(cos(obliquity) * sin(ecl_lon), cos(ecl_lon));
    if (ra < 0.0)
        ra += 2.0 * M_PI;
    double decl = asin(sin(obliquity) * sin(ecl_lon));
    /* local coordinates: zenith angle and azimuth from north through east */
    double gmst = 6.6974243242 + 0.0657098283 * n + ut;
    double lmst = (gmst * 15.0 + longitude) * M_PI / 180.0;
    double lat = latitude * M_PI / 180.0, ha = lmst - ra;
    double zenith = acos(cos(lat) * cos(ha) * cos(decl) + sin(decl) * sin(lat));
    double az = atan2(-sin(ha), tan(decl) * cos(lat) - sin(lat) * cos(ha));
    if (az < 0.0)
        az += 2.0 * M_PI;
    /* parallax: the Earth's mean radius over the astronomical unit (km) */
    zenith += (6371.01 / 149597890.0) * sin(zenith);
    *theta = zenith;
    *phi = az;
}

/* The sun's position of node: sunDirection (world space, through xf's inverse into sky
 * coordinates) or the date, time and place, Mitsuba's defaults those of Tokyo at 3 pm on
 * 10 July 2010. */
static op_status sun_of(op_node *node, const op_matrix4 *xf, double *theta, double *phi,
                        op_error *err)
{
    static const char *when_where[] = {"latitude", "longitude", "timezone", "year", "month",
                                       "day", "hour", "minute", "second"};
    if (op_node_has(node, "sunDirection")) {
        for (size_t i = 0; i < sizeof when_where / sizeof when_where[0]; i++)
            if (op_node_has(node, when_where[i]))
                return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: give "
                                    "sunDirection or the time and place (%s), not both",
                                    node->file, node->line, node->type, when_where[i]);
        double d[3], z[3] = {0, 1, 0}, inv_d[3];
        op_matrix4 inv;
        GET_OR_FAIL(op_node_vec3(node, "sunDirection", z, d, err));
        if (!op_matrix4_inverse(xf, &inv))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: toWorld is "
                                "singular", node->file, node->line, node->type);
        op_matrix4_vector(&inv, d, inv_d);
        double len = sqrt(inv_d[0] * inv_d[0] + inv_d[1] * inv_d[1] + inv_d[2] * inv_d[2]);
        if (!(len > 0.0) || !isfinite(len))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: zero or "
                                "non-finite sunDirection", node->file, node->line, node->type);
        *theta = acos(fmax(-1.0, fmin(1.0, inv_d[1] / len)));
        *phi = atan2(inv_d[0], -inv_d[2]);
        if (*phi < 0.0)
            *phi += 2.0 * M_PI;
        return OP_OK;
    }
    double lat, lon, tz, h, mi, se;
    long long y, mo, da;
    GET_OR_FAIL(op_node_float(node, "latitude", 35.6894, &lat, err));
    GET_OR_FAIL(op_node_float(node, "longitude", 139.6917, &lon, err));
    GET_OR_FAIL(op_node_float(node, "timezone", 9.0, &tz, err));
    GET_OR_FAIL(op_node_int(node, "year", 2010, &y, err));
    GET_OR_FAIL(op_node_int(node, "month", 7, &mo, err));
    GET_OR_FAIL(op_node_int(node, "day", 10, &da, err));
    GET_OR_FAIL(op_node_float(node, "hour", 15.0, &h, err));
    GET_OR_FAIL(op_node_float(node, "minute", 0.0, &mi, err));
    GET_OR_FAIL(op_node_float(node, "second", 0.0, &se, err));
    if (y < -100000 || y > 100000 || mo < 1 || mo > 12 || da < 1 || da > 31 ||
        !(fabs(lat) <= 90.0) || !(fabs(lon) <= 360.0) || !(fabs(tz) <= 24.0) ||
        !(fabs(h) <= 1e6) || !(fabs(mi) <= 1e6) || !(fabs(se) <= 1e6))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: the date, time or "
                            "place is out of range", node->file, node->line, node->type);
    op_sun_position((int)y, (int)mo, (int)da, h, mi, se, lat, lon, tz, theta, phi);
    return OP_OK;
}

op_status op_sky_build(op_node *node, const op_matrix4 *xf, long long max_pixels,
                       op_sky_model *m, op_image *img, op_error *err)
{
    double turbidity, stretch, scale, albedo[3], def[3] = {0.2, 0.2, 0.2}, theta, phi;
    long long res;
    int extend;
    GET_OR_FAIL(op_node_float(node, "turbidity", 3.0, &turbidity, err));
    GET_OR_FAIL(op_node_float(node, "stretch", 1.0, &stretch, err));
    GET_OR_FAIL(op_node_float(node, "scale", 1.0, &scale, err));
    GET_OR_FAIL(op_node_color(node, "albedo", def, albedo, err));
    GET_OR_FAIL(op_node_int(node, "resolution", 512, &res, err));
    GET_OR_FAIL(op_node_bool(node, "extend", 0, &extend, err));
    if (!(turbidity >= 1.0 && turbidity <= 10.0) || !(stretch >= 1.0 && stretch <= 2.0) ||
        !(scale >= 0.0) || !isfinite(scale))
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: need turbidity in "
                            "[1, 10], stretch in [1, 2] and a finite scale >= 0", node->file,
                            node->line, node->type);
    for (int c = 0; c < 3; c++)
        if (!(albedo[c] >= 0.0 && albedo[c] <= 1.0))
            return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: albedo must be "
                                "in [0, 1]", node->file, node->line, node->type);
    if (res < 2 || res > OP_IMAGE_MAX_SIDE || (res / 2) * res > max_pixels)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: resolution %lld "
                            "must be in 2..%d, its %lld x %lld map within the image-pixels limit "
                            "of %lld", node->file, node->line, node->type, res,
                            OP_IMAGE_MAX_SIDE, res, res / 2, max_pixels);
    GET_OR_FAIL(sun_of(node, xf, &theta, &phi, err));
    if (theta > 0.5 * M_PI)
        return op_error_set(err, OP_ERR_INPUT, "%s:%d: <emitter type=\"%s\">: the sun is below "
                            "the horizon (%.2f degrees from the zenith), which the sky model "
                            "does not cover", node->file, node->line, node->type,
                            theta * 180.0 / M_PI);
    op_sky_model_init(m, turbidity, albedo, theta, phi);
    m->stretch = stretch;
    m->scale = scale;
    m->extend = extend;
    int w = (int)res, h = (int)(res / 2);
    GET_OR_FAIL(op_image_alloc(img, w, h, 3, err));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double rgb[3];
            op_sky_radiance(m, M_PI * (y + 0.5) / h, 2.0 * M_PI * (x + 0.5) / w, rgb);
            float *px = img->pixels + 3 * ((size_t)y * w + x);
            for (int c = 0; c < 3; c++)
                px[c] = (float)rgb[c];
        }
    return OP_OK;
}
