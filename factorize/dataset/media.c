/* media.c - the media table: Jensen et al. 2001 (as reproduced by pbrt-v4 and Mitsuba 0.6),
 * two media of Narasimhan et al. 2006 (as reproduced by pbrt-v4), blends of those by volume
 * for the presets, and opaline's own dark "Vein" medium for the veined marbles. */
#include "media.h"

#include <strings.h>

#define JENSEN "Jensen et al. 2001, Table 1 (measured)"
#define NARASIMHAN "Narasimhan et al. 2006, Table 1 (measured; as in pbrt-v4 media.cpp)"

static const op_medium media[] = {
    {"Apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}, JENSEN},
    {"Chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}, JENSEN},
    {"Chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}, JENSEN},
    {"Cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}, JENSEN},
    {"Ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}, JENSEN},
    {"Marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}, JENSEN},
    {"Potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}, JENSEN},
    {"Skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, JENSEN},
    {"Skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, JENSEN},
    {"Skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}, JENSEN},
    {"Spectralon", {11.6, 20.4, 14.9}, {0.0, 0.0, 0.0}, JENSEN},
    {"Wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}, JENSEN},
    /* Not measured: a dark, strongly absorbing medium (single-scattering albedo about 0.3) for
     * the light-blocking veins of the veined marbles. */
    {"Vein", {1.5, 1.5, 1.5}, {3.0, 3.3, 3.6}, "opaline (synthetic light-blocking vein)"},
    /* Narasimhan, Gupta, Donner, Ramamoorthi, Nayar, Jensen 2006, "Acquiring scattering
     * properties of participating media by dilution", undiluted values in 1/mm as pbrt-v4
     * tabulates them (sigma_s used as the reduced coefficient). Nearly pure absorbers: dyes
     * for the blends below, not media to simulate on their own with diffusion. */
    {"Gatorade", {0.0024574, 0.003007, 0.0037325}, {0.024794, 0.019289, 0.008878}, NARASIMHAN},
    {"StrawberryShampoo", {0.00015671, 0.00015947, 1.518e-05}, {0.01449, 0.05796, 0.075823},
     NARASIMHAN},
    /* Blends by volume of the media above (coefficients mix linearly with volume fraction):
     * no published jade, wax or soap exists in these tables, so these stand in for them. The
     * values are the weighted sums, to the digits shown (tests/c/test_dataset_layouts.c checks
     * them against their parents). */
    {"Jade", {0.54159731, 0.63095455, 0.684926125}, {0.0168961, 0.01470785, 0.0251907},
     "blend by volume: 0.2 Marble + 0.65 Gatorade + 0.15 Potato (Jensen 2001, Narasimhan 2006)"},
    {"RedWax", {5.22, 3.85, 2.214}, {0.01844, 0.29296, 0.44641},
     "blend by volume: 0.7 Cream + 0.3 Ketchup (Jensen et al. 2001)"},
    {"PinkSoap", {1.020094026, 1.284095682, 1.508009108}, {0.009134, 0.035736, 0.0510938},
     "blend by volume: 0.4 Wholemilk + 0.6 StrawberryShampoo (Jensen 2001, Narasimhan 2006)"},
};

int op_medium_count(void)
{
    return (int)(sizeof media / sizeof media[0]);
}

const op_medium *op_medium_at(int i)
{
    return i >= 0 && i < op_medium_count() ? &media[i] : 0;
}

const op_medium *op_medium_find(const char *name)
{
    for (int i = 0; name && i < op_medium_count(); i++)
        if (!strcasecmp(name, media[i].name))
            return &media[i];
    return 0;
}
