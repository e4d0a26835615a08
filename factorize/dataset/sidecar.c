/* sidecar.c - the JSON sidecar reader (see sidecar.h). */
#include "sidecar.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A small strict JSON reader: enough to pick the top-level keys of the sidecar. */
typedef struct json {
    const char *p, *base, *path;
    op_error *err;
} json;

static void json_ws(json *j)
{
    while (*j->p == ' ' || *j->p == '\t' || *j->p == '\n' || *j->p == '\r')
        j->p++;
}

static op_status json_fail(json *j, const char *what)
{
    return op_error_set(j->err, OP_ERR_INPUT, "%s: bad JSON at byte %ld: %s", j->path,
                        (long)(j->p - j->base), what);
}

/* Reads a string into buf (n bytes, truncated); non-ASCII escapes become '?'. */
static op_status json_string(json *j, char *buf, size_t n)
{
    if (*j->p != '"')
        return json_fail(j, "expected a string");
    j->p++;
    size_t k = 0;
    while (*j->p && *j->p != '"') {
        char c = *j->p++;
        if ((unsigned char)c < 0x20)
            return json_fail(j, "control character in a string");
        if (c == '\\') {
            char e = *j->p++;
            switch (e) {
            case '"': case '\\': case '/': c = e; break;
            case 'b': case 'f': case 'n': case 'r': case 't': c = ' '; break;
            case 'u':
                for (int i = 0; i < 4; i++)
                    if (!strchr("0123456789abcdefABCDEF", *j->p++) || !j->p[-1])
                        return json_fail(j, "bad \\u escape");
                c = '?';
                break;
            default: return json_fail(j, "bad escape");
            }
        }
        if (buf && k + 1 < n)
            buf[k++] = c;
    }
    if (*j->p != '"')
        return json_fail(j, "unterminated string");
    j->p++;
    if (buf && n)
        buf[k] = '\0';
    return OP_OK;
}

static op_status json_number(json *j, double *out)
{
    char *end;
    if (!strchr("-0123456789", *j->p))
        return json_fail(j, "expected a number");
    double v = strtod(j->p, &end);
    if (end == j->p)
        return json_fail(j, "expected a number");
    j->p = end;
    if (out)
        *out = v;
    return OP_OK;
}

static op_status json_skip(json *j, int depth)
{
    json_ws(j);
    if (depth > 32)
        return json_fail(j, "nested too deeply");
    if (*j->p == '"')
        return json_string(j, NULL, 0);
    if (*j->p == '{' || *j->p == '[') {
        char close = *j->p == '{' ? '}' : ']';
        int obj = close == '}';
        j->p++;
        json_ws(j);
        if (*j->p == close) {
            j->p++;
            return OP_OK;
        }
        for (;;) {
            json_ws(j);
            if (obj) {
                if (json_string(j, NULL, 0) != OP_OK)
                    return j->err ? j->err->status : OP_ERR_INPUT;
                json_ws(j);
                if (*j->p++ != ':')
                    return json_fail(j, "expected ':'");
            }
            op_status st = json_skip(j, depth + 1);
            if (st != OP_OK)
                return st;
            json_ws(j);
            if (*j->p == ',') {
                j->p++;
                continue;
            }
            if (*j->p++ == close)
                return OP_OK;
            return json_fail(j, "expected ',' or a closing bracket");
        }
    }
    static const char *words[] = {"true", "false", "null"};
    for (int i = 0; i < 3; i++)
        if (!strncmp(j->p, words[i], strlen(words[i]))) {
            j->p += strlen(words[i]);
            return OP_OK;
        }
    return json_number(j, NULL);
}

op_status op_sidecar_parse(const char *text, size_t n, const char *path, op_sidecar *sc,
                           op_error *err)
{
    memset(sc, 0, sizeof *sc);
    if (strlen(text) != n)
        return op_error_set(err, OP_ERR_INPUT, "%s: NUL byte in the sidecar", path);
    int have_size = 0;
    json j = {text, text, path, err};
    op_status st = OP_OK;
    json_ws(&j);
    if (*j.p++ != '{') {
        st = json_fail(&j, "the sidecar must be a JSON object");
        goto out;
    }
    json_ws(&j);
    if (*j.p == '}')
        j.p++;
    else
        for (;;) {
            char key[64];
            json_ws(&j);
            if ((st = json_string(&j, key, sizeof key)) != OP_OK)
                goto out;
            json_ws(&j);
            if (*j.p++ != ':') {
                st = json_fail(&j, "expected ':'");
                goto out;
            }
            json_ws(&j);
            if (!strcmp(key, "size_cm")) {
                if (*j.p++ != '[') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                json_ws(&j);
                if ((st = json_number(&j, &sc->size_x_cm)) != OP_OK)
                    goto out;
                json_ws(&j);
                if (*j.p++ != ',') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                json_ws(&j);
                if ((st = json_number(&j, &sc->size_y_cm)) != OP_OK)
                    goto out;
                json_ws(&j);
                if (*j.p++ != ']') {
                    st = json_fail(&j, "size_cm must be [X, Y]");
                    goto out;
                }
                have_size = 1;
            } else if (!strcmp(key, "name")) {
                if ((st = json_string(&j, sc->name, sizeof sc->name)) != OP_OK)
                    goto out;
            } else if (!strcmp(key, "source")) {
                if ((st = json_string(&j, sc->source, sizeof sc->source)) != OP_OK)
                    goto out;
            } else {
                op_log(OP_LOG_WARN, "%s: ignoring unknown key '%s'", path, key);
                if ((st = json_skip(&j, 0)) != OP_OK)
                    goto out;
            }
            json_ws(&j);
            if (*j.p == ',') {
                j.p++;
                continue;
            }
            if (*j.p++ == '}')
                break;
            st = json_fail(&j, "expected ',' or '}'");
            goto out;
        }
    json_ws(&j);
    if (*j.p) {
        st = json_fail(&j, "text after the object");
        goto out;
    }
    if (!have_size)
        st = op_error_set(err, OP_ERR_INPUT, "%s: no \"size_cm\": [X, Y] (the physical size in "
                                             "cm)", path);
    else if (!(sc->size_x_cm > 0) || !(sc->size_y_cm > 0) || !isfinite(sc->size_x_cm) ||
             !isfinite(sc->size_y_cm))
        st = op_error_set(err, OP_ERR_INPUT, "%s: size_cm %g x %g must be positive", path,
                          sc->size_x_cm, sc->size_y_cm);
out:
    return st;
}
