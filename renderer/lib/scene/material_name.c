/* material_name.c - the plugin's long material names (see material_name.h). */
#include "scene/material_name.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int op_parse_long_material_name(const char *name, char *out, size_t n, op_method *method, double *a,
                           double *b)
{
    char buf[512], res[512];
    if (strlen(name) >= sizeof buf)
        return 0;
    strcpy(buf, name);
    char *tok[64], *save = NULL;
    int nt = 0;
    for (char *t = strtok_r(buf, " \t", &save); t && nt < 64; t = strtok_r(NULL, " \t", &save))
        tok[nt++] = t;
    int forat = -1;
    for (int i = 1; i + 1 < nt; i++)
        if (strcasecmp(tok[i], "for") == 0 && strcasecmp(tok[i + 1], "Rd") == 0) {
            forat = i;
            break;
        }
    if (forat < 1 || forat + 2 >= nt)
        return 0;
    char low[32];
    size_t ml = strlen(tok[0]);
    if (ml == 0 || ml >= sizeof low)
        return 0;
    for (size_t i = 0; i <= ml; i++)
        low[i] = (char)tolower((unsigned char)tok[0][i]);
    op_method m = op_method_from_name(low);
    if (m == OP_METHOD_COUNT)
        return 0;
    double A = 0.0, B = 0.0;
    size_t k = 0;
    for (size_t i = 0; i < ml; i++)
        res[k++] = (char)toupper((unsigned char)tok[0][i]);
    for (int i = 1; i < forat; i++) {
        const char *t = tok[i];
        size_t letters = 0;
        while (isalpha((unsigned char)t[letters]))
            letters++;
        char *end;
        double v = strtod(t + letters, &end);
        if (letters == 0 || end == t + letters || *end || !isfinite(v))
            return 0;
        if (letters == 3 && strncasecmp(t, "Div", 3) == 0) {
            A = v;
        } else if (letters == 3 && strncasecmp(t, "Add", 3) == 0) {
            B = v;
        } else {
            int w = snprintf(res + k, sizeof res - k, "_%c%s", toupper((unsigned char)t[0]), t + 1);
            if (w < 0 || (size_t)w >= sizeof res - k)
                return 0;
            k += (size_t)w;
        }
    }
    const char *nm = tok[forat + 2];
    for (const char *p = nm; *p; p++)
        if (!isalnum((unsigned char)*p) && *p != '_' && *p != '-')
            return 0;
    int w = snprintf(res + k, sizeof res - k, "_%s", nm);
    if (w < 0 || (size_t)w >= sizeof res - k || k + (size_t)w >= n)
        return 0;
    memcpy(out, res, k + (size_t)w + 1);
    *method = m;
    *a = A;
    *b = B;
    return 1;
}
