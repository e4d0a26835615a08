/* bench_sss_reference.c - opaline-bench-sss-reference [PHOTONS [MEDIUM]]: the table of
 * tests/c/mc_reference.h (the subsurface renderer against the Monte Carlo generator's own
 * transport, with the renderer's dipole and the dipole's closed form) for several media and
 * channels, PHOTONS (200000) per row, every medium of the table or MEDIUM only. Run by
 * bench/bench_sss_reference.sh; the measurement runs as one cmocka test (its steps fail it). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <strings.h>

#include "mc_reference.h"
#include "test_support.h"

static uint64_t table_photons = 200000;
static const char *table_only; /* NULL, or the one medium to run */

static void table(void **state)
{
    (void)state;
    static const struct {
        const char *medium;
        int channel;
    } cases[] = {{"Skin1", 0}, {"Skin1", 1}, {"Skin1", 2}, {"Ketchup", 0}, {"Ketchup", 1},
                 {"Skin2", 2}, {"Potato", 2}, {"Chicken1", 1}, {"Skimmilk", 2}, {"Marble", 2}};
    printf("(a) the MC rows' exact answer, mean of 3 independent rows (+- its standard error); "
           "(b) raw render of those rows, (b)/(a) - 1 averaged over the rows [mean z-score]; "
           "(c) the renderer's dipole / (a) - 1; (d) the dipole's closed form / (a) - 1; "
           "(c)/(d) - 1: the renderer's own dipole error\n");
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        if (table_only && strcasecmp(table_only, cases[i].medium))
            continue;
        mcref_case k = {cases[i].medium, cases[i].channel, table_photons, 6.0, 1};
        mcref_result r;
        mcref_run(&k, &r);
        /* (a) pooled over the three replicas; (b) against each replica, shown as the mean */
        double a[4], se[4], b[4], z[4];
        for (int q = 0; q < 4; q++) {
            a[q] = se[q] = b[q] = z[q] = 0.0;
            for (int c = 0; c < 3; c++) {
                a[q] += r.ref[c][q] / 3.0;
                se[q] += r.se[c][q] * r.se[c][q] / 9.0;
                b[q] += (r.got[c][q] / r.ref[c][q] - 1.0) / 3.0;
                z[q] += (r.got[c][q] - r.ref[c][q]) / r.se[c][q] / 3.0;
            }
            se[q] = sqrt(se[q]);
        }
        double rows = (r.rowsum[0] + r.rowsum[1] + r.rowsum[2]) / 3.0;
        double all = (r.mc_total[0] + r.mc_total[1] + r.mc_total[2]) / 3.0;
        double ub = (r.uni_got[0] / r.rowsum[0] + r.uni_got[1] / r.rowsum[1] +
                     r.uni_got[2] / r.rowsum[2]) / 3.0 - 1.0;
        printf("\n%s channel %d (grey): L %.3f mm, pixel %.3f mm, K %d, spot radius 2 L, "
               "%d points, %llu photons per row; MC %.1f s, raw %.1f s, dipole %.1f s "
               "(pre-passes)\n",
               k.medium, k.channel, r.L, r.pix, r.K, r.points,
               (unsigned long long)table_photons, r.mc_seconds, r.raw_seconds, r.dip_seconds);
        printf("  where          (a) MC rows            (b)-(a)          (c)-(a)   (d)-(a)"
               "   (c)-(d)\n");
        static const char *where[4] = {"1 L outside", "2 L outside", "4 L outside", "total"};
        for (int q = 0; q < 4; q++)
            printf("  %-11s  %.4e +- %4.1f %%  %+6.2f %% [%+4.1f]  %+7.2f %% %+7.2f %% %+7.2f %%\n",
                   where[q], a[q], 100.0 * se[q] / a[q], 100.0 * b[q], z[q],
                   100.0 * (r.dip[q] / a[q] - 1.0), 100.0 * (r.cf[q] / a[q] - 1.0),
                   100.0 * (r.dip[q] / r.cf[q] - 1.0));
        printf("  uniform      %.4f (row sum; all escaping %.4f)  %+6.3f %%  %+7.2f %% %+7.2f %% "
               "%+7.2f %%\n",
               rows, all, 100.0 * ub, 100.0 * (r.dip_uni / rows - 1.0),
               100.0 * (r.cf_uni / rows - 1.0), 100.0 * (r.dip_uni / r.cf_uni - 1.0));
        fflush(stdout);
    }
}

int main(int argc, char **argv)
{
    op_log_set_level(OP_LOG_WARN);
    if (argc > 1)
        table_photons = strtoull(argv[1], NULL, 10);
    if (argc > 2)
        table_only = argv[2];
    const struct CMUnitTest t[] = {cmocka_unit_test(table)};
    return cmocka_run_group_tests(t, NULL, NULL);
}
