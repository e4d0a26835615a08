/* media.c - the one media table (see opaline.h): Jensen et al. 2001 (as reproduced by pbrt-v4
 * and Mitsuba 0.6), two media of Narasimhan et al. 2006 (as reproduced by pbrt-v4), blends of
 * those by volume for the presets, and opaline's own dark "Vein" medium for the veined marbles.
 * Indices of refraction: 1.3 for every medium (Jensen et al. 2001 and Mitsuba 0.6's default for
 * these media), 1.5 for Marble (Mitsuba 0.6's value for marble, near calcite's 1.49 to 1.66)
 * and for the marble's Vein; the blends keep 1.3 (docs/datasets.md). */
#include "opaline.h"

#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#define JENSEN "Jensen et al. 2001, Table 1 (measured)"
#define NARASIMHAN "Narasimhan et al. 2006, Table 1 (measured; as in pbrt-v4 media.cpp)"

static const op_medium media[] = {
    {"Apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}, 1.3, JENSEN},
    {"Chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}, 1.3, JENSEN},
    {"Chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}, 1.3, JENSEN},
    {"Cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}, 1.3, JENSEN},
    {"Ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}, 1.3, JENSEN},
    {"Marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}, 1.5, JENSEN},
    {"Potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}, 1.3, JENSEN},
    {"Skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, 1.3, JENSEN},
    {"Skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, 1.3, JENSEN},
    {"Skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}, 1.3, JENSEN},
    {"Spectralon", {11.6, 20.4, 14.9}, {0.0, 0.0, 0.0}, 1.3, JENSEN},
    {"Wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}, 1.3, JENSEN},
    /* Not measured: a dark, strongly absorbing medium (single-scattering albedo about 0.3) for
     * the light-blocking veins of the veined marbles. */
    {"Vein", {1.5, 1.5, 1.5}, {3.0, 3.3, 3.6}, 1.5, "opaline (synthetic light-blocking vein)"},
    /* Narasimhan, Gupta, Donner, Ramamoorthi, Nayar, Jensen 2006, "Acquiring scattering
     * properties of participating media by dilution", undiluted values in 1/mm as pbrt-v4
     * tabulates them (sigma_s used as the reduced coefficient). Nearly pure absorbers: dyes
     * for the blends below, not media to simulate on their own with diffusion. */
    {"Gatorade", {0.0024574, 0.003007, 0.0037325}, {0.024794, 0.019289, 0.008878}, 1.3, NARASIMHAN},
    {"StrawberryShampoo", {0.00015671, 0.00015947, 1.518e-05}, {0.01449, 0.05796, 0.075823},
     1.3, NARASIMHAN},
    /* Blends by volume of the media above (coefficients mix linearly with volume fraction):
     * no published jade, wax or soap exists in these tables, so these stand in for them. The
     * values are the weighted sums, to the digits shown (tests/c/test_dataset_layouts.c checks
     * them against their parents). */
    {"Jade", {0.54159731, 0.63095455, 0.684926125}, {0.0168961, 0.01470785, 0.0251907},
     1.3, "blend by volume: 0.2 Marble + 0.65 Gatorade + 0.15 Potato (Jensen 2001, Narasimhan 2006)"},
    {"RedWax", {5.22, 3.85, 2.214}, {0.01844, 0.29296, 0.44641},
     1.3, "blend by volume: 0.7 Cream + 0.3 Ketchup (Jensen et al. 2001)"},
    {"PinkSoap", {1.020094026, 1.284095682, 1.508009108}, {0.009134, 0.035736, 0.0510938},
     1.3, "blend by volume: 0.4 Wholemilk + 0.6 StrawberryShampoo (Jensen 2001, Narasimhan 2006)"},
};

int op_medium_count(void)
{
    return (int)(sizeof media / sizeof media[0]);
}

const op_medium *op_medium_at(int i)
{
    return i >= 0 && i < op_medium_count() ? &media[i] : 0;
}

const op_medium *op_medium_lookup(const char *name)
{
    for (int i = 0; name && i < op_medium_count(); i++)
        if (!strcasecmp(name, media[i].name))
            return &media[i];
    return 0;
}

static char names[512];
static pthread_once_t names_once = PTHREAD_ONCE_INIT;

static void join_names(void)
{
    size_t n = 0;
    for (int i = 0; i < op_medium_count() && n < sizeof names; i++)
        n += (size_t)snprintf(names + n, sizeof names - n, "%s%s", i ? ", " : "", media[i].name);
}

const char *op_medium_names(void)
{
    pthread_once(&names_once, join_names);
    return names;
}
