/* test_dataset_layouts.c - the preset library's layouts (inclusions, strata, skin) give the
 * structure they promise and are pure functions of their arguments; the preset datasets stay
 * within their media's albedos and are deterministic; the blended media are what their
 * sources say. */
#include "test_support.h"

#include "dataset_generate.h"
#include "dataset_layout.h"
#include "opaline.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *preset_datasets[] = {"carrara-marble", "jade", "layered-wax", "soap", "skin"};
#define N_PRESET_DATASETS (sizeof preset_datasets / sizeof preset_datasets[0])

static const op_medium *medium(const char *name)
{
    const op_medium *m = op_medium_lookup(name);
    assert_non_null(m);
    return m;
}

/* 4-connected components of medium 1 on the periodic map (flood fill). */
static int components(const op_layout *l)
{
    size_t n = (size_t)l->width * (size_t)l->height;
    uint8_t *seen = calloc(n, 1);
    size_t *stack = malloc(n * sizeof *stack);
    assert_non_null(seen);
    assert_non_null(stack);
    int count = 0;
    for (size_t s = 0; s < n; s++) {
        if (!l->map[s] || seen[s])
            continue;
        count++;
        size_t top = 0;
        stack[top++] = s;
        seen[s] = 1;
        while (top) {
            size_t i = stack[--top];
            int x = (int)(i % (size_t)l->width), y = (int)(i / (size_t)l->width);
            static const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
            for (int k = 0; k < 4; k++) {
                int nx = (x + dx[k] + l->width) % l->width;
                int ny = (y + dy[k] + l->height) % l->height;
                size_t j = (size_t)ny * (size_t)l->width + (size_t)nx;
                if (l->map[j] && !seen[j]) {
                    seen[j] = 1;
                    stack[top++] = j;
                }
            }
        }
    }
    free(seen);
    free(stack);
    return count;
}

static int same_map(const op_layout *a, const op_layout *b)
{
    return a->width == b->width && a->height == b->height &&
           !memcmp(a->map, b->map, (size_t)a->width * (size_t)a->height);
}

/* Inclusions cover exactly the requested fraction, as separate blobs, and depend on the seed
 * only. */
static void inclusions_cover_the_fraction(void **state)
{
    (void)state;
    const op_medium *a = medium("Jade"), *b = medium("Marble");
    const double fractions[] = {0, 0.05, 0.15, 0.5, 1};
    for (size_t i = 0; i < sizeof fractions / sizeof fractions[0]; i++) {
        op_layout l, again, other;
        op_error err = {0};
        OP_ASSERT_OK(op_layout_inclusions(&l, 96, 80, 4.8, 4.0, fractions[i], 1.5, 7, a, b, &err),
                     err);
        double want = round(fractions[i] * 96 * 80) / (96 * 80);
        assert_true(fabs(op_layout_fraction(&l) - want) < 1e-12);
        OP_ASSERT_OK(op_layout_inclusions(&again, 96, 80, 4.8, 4.0, fractions[i], 1.5, 7, a, b,
                                          &err), err);
        assert_true(same_map(&l, &again));
        OP_ASSERT_OK(op_layout_inclusions(&other, 96, 80, 4.8, 4.0, fractions[i], 1.5, 8, a, b,
                                          &err), err);
        if (fractions[i] > 0 && fractions[i] < 1)
            assert_false(same_map(&l, &other));
        if (fractions[i] == 0.15) {
            /* 48 x 40 mm at 15 % in blobs of about 1.5 mm: many separate inclusions. */
            int blobs = components(&l);
            print_message("inclusions: %d blobs\n", blobs);
            assert_true(blobs >= 10 && blobs <= 120);
        }
        op_layout_free(&l);
        op_layout_free(&again);
        op_layout_free(&other);
    }
    op_layout l;
    op_error err = {0};
    assert_int_equal(op_layout_inclusions(&l, 8, 8, 1, 1, 1.5, 1, 1, a, b, &err), OP_ERR_INPUT);
    assert_int_equal(op_layout_inclusions(&l, 8, 8, 1, 1, 0.5, 0, 1, a, b, &err), OP_ERR_INPUT);
}

/* Every column crosses exactly `count` bands whose mean thickness is the requested one. */
static void layers_have_the_count_and_thickness(void **state)
{
    (void)state;
    const op_medium *a = medium("Cream"), *b = medium("RedWax");
    const int counts[] = {1, 5, 8};
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++) {
        op_layout l, again;
        op_error err = {0};
        double layer_mm = 3.0;
        OP_ASSERT_OK(op_layout_layers(&l, 100, 128, 5.0, 6.4, counts[i], layer_mm, 2.0, 3, a, b,
                                      &err), err);
        long runs_total = 0, ones_total = 0;
        for (int x = 0; x < l.width; x++) {
            int runs = 0, ones = 0;
            for (int y = 0; y < l.height; y++) {
                int here = op_layout_at(&l, x, y), above = op_layout_at(&l, x, y - 1);
                runs += here && !above;
                ones += here;
            }
            assert_int_equal(runs, counts[i]);
            runs_total += runs;
            ones_total += ones;
        }
        double mean_mm = (double)ones_total / (double)runs_total * l.pixel_y;
        print_message("layers: %d bands, mean thickness %.3f mm\n", counts[i], mean_mm);
        assert_true(fabs(mean_mm - layer_mm) < 0.1 * layer_mm);
        /* The bands wave: some band starts at different rows in different columns. */
        int waves = 0;
        for (int x = 1; x < l.width && !waves; x++)
            for (int y = 0; y < l.height && !waves; y++)
                waves = op_layout_at(&l, x, y) != op_layout_at(&l, 0, y);
        assert_true(waves);
        OP_ASSERT_OK(op_layout_layers(&again, 100, 128, 5.0, 6.4, counts[i], layer_mm, 2.0, 3, a,
                                      b, &err), err);
        assert_true(same_map(&l, &again));
        op_layout_free(&l);
        op_layout_free(&again);
    }
    op_layout l;
    op_error err = {0};
    /* Thicker than half the period (64 mm / 12 bands / 2 = 2.67 mm), or under 4/3 pixel. */
    assert_int_equal(op_layout_layers(&l, 100, 128, 5.0, 6.4, 12, 3.0, 0, 1, a, b, &err),
                     OP_ERR_INPUT);
    assert_int_equal(op_layout_layers(&l, 100, 128, 5.0, 6.4, 4, 0.5, 0, 1, a, b, &err),
                     OP_ERR_INPUT);
    assert_int_equal(op_layout_layers(&l, 100, 128, 5.0, 6.4, 0, 1.0, 0, 1, a, b, &err),
                     OP_ERR_INPUT);
}

/* Without veins, one separate pore per grid cell; veins add connected lines. */
static void skin_has_pores_and_veins(void **state)
{
    (void)state;
    const op_medium *a = medium("Skin2"), *b = medium("Skin1");
    op_layout pores, veined, again;
    op_error err = {0};
    OP_ASSERT_OK(op_layout_skin(&pores, 128, 128, 3.84, 3.84, 3.0, 0.55, 0, 5, a, b, &err), err);
    int want = op_layout_skin_pores(128, 128, 3.84, 3.84, 3.0);
    assert_int_equal(want, 13 * 13);
    assert_int_equal(components(&pores), want);
    OP_ASSERT_OK(op_layout_skin(&veined, 128, 128, 3.84, 3.84, 3.0, 0.55, 0.7, 5, a, b, &err),
                 err);
    double fp = op_layout_fraction(&pores), fv = op_layout_fraction(&veined);
    print_message("skin: pores %.3f, with veins %.3f, %d pieces\n", fp, fv, components(&veined));
    assert_true(fp > 0.02 && fp < 0.15);
    assert_true(fv > fp + 0.02 && fv < 0.4);
    assert_true(components(&veined) < want); /* veins join pores */
    OP_ASSERT_OK(op_layout_skin(&again, 128, 128, 3.84, 3.84, 3.0, 0.55, 0.7, 5, a, b, &err),
                 err);
    assert_true(same_map(&veined, &again));
    op_layout_free(&pores);
    op_layout_free(&veined);
    op_layout_free(&again);
    op_layout l;
    assert_int_equal(op_layout_skin(&l, 8, 8, 1, 1, 3.0, 0.7, 0, 1, a, b, &err), OP_ERR_INPUT);
}

/* Row sums (albedos within the kernel) of every preset dataset lie between those of its two
 * media alone at the sample's one index (its base medium's), to 0.1 % (a pixel near a boundary
 * sees mixed coefficients, whose kernel sum is not exactly monotone in the mix); the same spec
 * gives the same bytes, another seed other bytes. */
static void preset_datasets_stay_within_their_media(void **state)
{
    (void)state;
    for (size_t i = 0; i < N_PRESET_DATASETS; i++) {
        op_dataset_spec s;
        op_error err = {0};
        OP_ASSERT_OK(op_dataset_spec_defaults(preset_datasets[i], &s, &err), err);
        /* A 48 x 48 corner of the preset at its own pixel pitch, with a smaller kernel. */
        s.size_x_cm *= 48.0 / s.width;
        s.size_y_cm *= 48.0 / s.height;
        s.width = s.height = 48;
        s.kernel = 9;
        s.threads = 2;
        op_dataset d, again, other, pure[2];
        OP_ASSERT_OK(op_dataset_generate(&s, &d, NULL, &err), err);
        OP_ASSERT_OK(op_dataset_generate(&s, &again, NULL, &err), err);
        assert_int_equal(op_dataset_crc(&d), op_dataset_crc(&again));
        op_dataset_spec s2 = s;
        s2.seed = 2;
        OP_ASSERT_OK(op_dataset_generate(&s2, &other, NULL, &err), err);
        assert_int_not_equal(op_dataset_crc(&d), op_dataset_crc(&other));
        for (int m = 0; m < 2; m++) {
            op_dataset_spec h = s;
            h.kind = OP_DS_HOMOGENEOUS;
            h.eta = s.eta ? s.eta : s.media[0]->eta;
            h.media[0] = h.media[1] = s.media[m];
            OP_ASSERT_OK(op_dataset_generate(&h, &pure[m], NULL, &err), err);
        }
        int cols = s.kernel * s.kernel;
        for (int c = 0; c < 3; c++) {
            double lo[2] = {0, 0};
            for (int m = 0; m < 2; m++)
                for (int j = 0; j < cols; j++)
                    lo[m] += pure[m].rd[c][j];
            double mn = fmin(lo[0], lo[1]), mx = fmax(lo[0], lo[1]);
            for (uint64_t r = 0; r < op_dataset_rows(&d); r++) {
                double sum = 0;
                for (int j = 0; j < cols; j++)
                    sum += d.rd[c][r * (uint64_t)cols + (uint64_t)j];
                if (!(sum >= mn * (1 - 1e-3) && sum <= mx * (1 + 1e-3)))
                    fail_msg("%s channel %d row %llu: albedo %g outside [%g, %g] of %s, %s",
                             preset_datasets[i], c, (unsigned long long)r, sum, mn, mx,
                             s.media[0]->name, s.media[1]->name);
            }
        }
        op_dataset_free(&d);
        op_dataset_free(&again);
        op_dataset_free(&other);
        op_dataset_free(&pure[0]);
        op_dataset_free(&pure[1]);
    }
}

/* Each blend is the volume-weighted sum of its published parents; each medium names a source. */
static void blends_are_their_parents(void **state)
{
    (void)state;
    static const struct {
        const char *name, *parent[3];
        double f[3];
    } blends[] = {
        {"Jade", {"Marble", "Gatorade", "Potato"}, {0.2, 0.65, 0.15}},
        {"RedWax", {"Cream", "Ketchup", NULL}, {0.7, 0.3, 0}},
        {"PinkSoap", {"Wholemilk", "StrawberryShampoo", NULL}, {0.4, 0.6, 0}},
    };
    for (size_t i = 0; i < sizeof blends / sizeof blends[0]; i++) {
        const op_medium *m = medium(blends[i].name);
        for (int c = 0; c < 3; c++) {
            double s = 0, a = 0;
            for (int p = 0; p < 3 && blends[i].parent[p]; p++) {
                s += blends[i].f[p] * medium(blends[i].parent[p])->sigma_s[c];
                a += blends[i].f[p] * medium(blends[i].parent[p])->sigma_a[c];
            }
            assert_true(fabs(m->sigma_s[c] - s) <= 1e-9 * s);
            assert_true(fabs(m->sigma_a[c] - a) <= 1e-9 * a);
        }
        assert_non_null(strstr(m->source, "blend by volume"));
    }
    for (int i = 0; i < op_medium_count(); i++)
        assert_true(op_medium_at(i)->source && op_medium_at(i)->source[0]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(inclusions_cover_the_fraction),
        cmocka_unit_test(layers_have_the_count_and_thickness),
        cmocka_unit_test(skin_has_pores_and_veins),
        cmocka_unit_test(preset_datasets_stay_within_their_media),
        cmocka_unit_test(blends_are_their_parents),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
