/* dialect.c - Mitsuba 0.x and Mitsuba 2/3 scene dialects (see dialect.h). */
#include "scene/dialect.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

int op_dialect_from_version(const char *version, op_dialect *d, int *unusual)
{
    int major = -1, minor = -1, patch = 0, used = 0;
    int n = sscanf(version, "%d.%d%n.%d%n", &major, &minor, &used, &patch, &used);
    *unusual = 0;
    if (n < 2 || major < 0 || minor < 0 || version[used] != '\0' || major > 3)
        return -1;
    if (major >= 2) {
        *d = OP_DIALECT_MITSUBA_3;
        return 0;
    }
    *d = OP_DIALECT_MITSUBA_0;
    *unusual = !(major == 0 && (minor == 5 || minor == 6));
    return 0;
}

const char *op_dialect_label(op_dialect d)
{
    return d == OP_DIALECT_MITSUBA_3 ? "Mitsuba 3" : "Mitsuba 0.6";
}

/* Mitsuba 3 spellings that the plain snake_case -> camelCase rule does not give. */
static const struct {
    const char *snake, *camel;
} renamed[] = {{"int_ior", "intIOR"}, {"ext_ior", "extIOR"}, {"to_uv", "toUV"}};

/* snake_case -> camelCase; -2 when it does not fit. */
static int to_camel(const char *s, char *out, size_t cap)
{
    for (size_t i = 0; i < sizeof renamed / sizeof renamed[0]; i++)
        if (strcmp(s, renamed[i].snake) == 0)
            return snprintf(out, cap, "%s", renamed[i].camel) < (int)cap ? 0 : -2;
    size_t k = 0;
    for (int up = 0; *s; s++) {
        if (*s == '_' && k > 0) {
            up = 1;
            continue;
        }
        if (k + 1 >= cap)
            return -2;
        out[k++] = up ? (char)toupper((unsigned char)*s) : *s;
        up = 0;
    }
    if (k >= cap)
        return -2;
    out[k] = '\0';
    return 0;
}

/* camelCase -> snake_case, for hints; -2 when it does not fit. */
static int to_snake(const char *s, char *out, size_t cap)
{
    for (size_t i = 0; i < sizeof renamed / sizeof renamed[0]; i++)
        if (strcmp(s, renamed[i].camel) == 0)
            return snprintf(out, cap, "%s", renamed[i].snake) < (int)cap ? 0 : -2;
    size_t k = 0;
    for (; *s; s++) {
        if (isupper((unsigned char)*s)) {
            if (k + 2 >= cap)
                return -2;
            if (k > 0 && out[k - 1] != '_')
                out[k++] = '_';
            out[k++] = (char)tolower((unsigned char)*s);
        } else {
            if (k + 1 >= cap)
                return -2;
            out[k++] = *s;
        }
    }
    out[k] = '\0';
    return 0;
}

/* Whether s is letters, digits and underscores only, the form of every parameter name. */
static int is_identifier(const char *s)
{
    for (; *s; s++)
        if (!isalnum((unsigned char)*s) && *s != '_')
            return 0;
    return 1;
}

static int has_upper(const char *s)
{
    for (; *s; s++)
        if (isupper((unsigned char)*s))
            return 1;
    return 0;
}

int op_dialect_param_name(op_dialect d, const char *spelled, char *out, size_t cap, char *hint,
                          size_t hcap)
{
    if (hcap > 0)
        hint[0] = '\0';
    if (!is_identifier(spelled)) /* "mat-Material", a Blender export's label: no one's parameter */
        return snprintf(out, cap, "%s", spelled) < (int)cap ? 0 : -2;
    if (d == OP_DIALECT_MITSUBA_3) {
        if (has_upper(spelled)) {
            if (to_snake(spelled, hint, hcap) != 0 && hcap > 0)
                hint[0] = '\0';
            return -1;
        }
        return to_camel(spelled, out, cap);
    }
    /* a leading or doubled underscore is nobody's Mitsuba 3 spelling: kept as written */
    const char *u = strchr(spelled, '_');
    if (u && u != spelled && u[1] && u[1] != '_') {
        if (to_camel(spelled, hint, hcap) != 0 && hcap > 0)
            hint[0] = '\0';
        return -1;
    }
    return snprintf(out, cap, "%s", spelled) < (int)cap ? 0 : -2;
}
