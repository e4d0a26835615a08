/* scene_xml.c - reads a Mitsuba 0.5/0.6 scene file into the tree of scene_desc.h.
 *
 * Each file is parsed by libxml2 into a DOM with its own parser context (no network, no
 * entity expansion, parse errors captured rather than printed), then walked in document
 * order: objects become nodes, values become typed properties, <include> splices another
 * file's <scene> children in place, and <ref>/<alias> are resolved once everything is read,
 * so a reference may point forwards. Parameters ($name) come from the -D defines first, then
 * from <default> elements. The bytes read (include-bytes), the <include>s followed
 * (include-count) and the attribute bytes after expansion (attribute-bytes) are counted as
 * they come and refused past their limits before the work or memory. Every error names
 * "file:line: <element ...>: what". */
#include "scene/scene_color.h"
#include "scene/dialect.h"
#include "scene/scene_desc_internal.h"
#include "scene/scene_path.h"
#include "math/transform.h"

#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include <libxml/parser.h>
#include <libxml/tree.h>
#include <libxml/xmlerror.h>

#define MAX_INCLUDE_DEPTH 32
#define MAX_SCENE_BYTES ((size_t)1 << 30)

typedef struct pending {
    op_node *parent; /* ref: where the placeholder child is */
    int index;
    char *id;        /* ref: the target id; alias: the existing id */
    char *as;        /* alias only: the new id */
    const char *file;
    int line;
} pending;

typedef struct xml_ctx {
    op_desc_tree *tree;
    op_error *err;
    const op_scene_limits *lim;
    op_strmap params, ids; /* parameters: key = name, value; ids: key = id, ptr = its node */
    long long include_bytes, includes, attribute_bytes; /* counted against lim */
    pending *refs, *aliases;
    int nrefs, cap_refs, naliases, cap_aliases;
    char *stack[MAX_INCLUDE_DEPTH]; /* canonical paths of the files being read */
    int depth;
    const char *file; /* the file being walked (interned) */
    op_dialect dialect; /* that file's */
} xml_ctx;

static op_status nomem(xml_ctx *c)
{
    return op_error_set(c->err, OP_ERR_NOMEM, "out of memory while reading the scene");
}

/* ---------------------------------------------------------------- errors */

/* The text of attribute a as parsed, without expanding entity references: libxml2 keeps a
 * value that references a declared entity as a list of text and entity-reference nodes, whose
 * expansion (xmlNodeListGetString) is quadratic in the number of references and exponential in
 * their nesting. Returns NULL when the value holds such a reference (character references and
 * the predefined entities are plain text by then). */
static const char *attr_text(const xmlAttr *a)
{
    const xmlNode *k = a->children;
    if (!k)
        return "";
    if (k->type != XML_TEXT_NODE || k->next)
        return NULL;
    return k->content ? (const char *)k->content : "";
}

/* "<tag type="..." id="..." name="...">" from the element's raw attributes. */
static void describe(xmlNode *e, char *buf, size_t cap)
{
    static const char *keys[] = {"type", "id", "name"};
    size_t k = (size_t)snprintf(buf, cap, "<%s", (const char *)e->name);
    for (int i = 0; i < 3 && k < cap; i++) {
        xmlAttr *a = xmlHasNsProp(e, (const xmlChar *)keys[i], NULL);
        if (a) {
            const char *v = attr_text(a);
            k += (size_t)snprintf(buf + k, cap - k, " %s=\"%.60s%s\"", keys[i], v ? v : "&...;",
                                  v && strlen(v) > 60 ? "..." : "");
        }
    }
    if (k < cap)
        snprintf(buf + k, cap - k, ">");
}

static op_status elem_error(xml_ctx *c, xmlNode *e, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static op_status elem_error(xml_ctx *c, xmlNode *e, const char *fmt, ...)
{
    char msg[640], desc[300];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    describe(e, desc, sizeof desc);
    return op_error_set(c->err, OP_ERR_INPUT, "%s:%ld: %s: %s", c->file, xmlGetLineNo(e), desc, msg);
}

/* ---------------------------------------------------------------- parameters */

static const char *param_get(xml_ctx *c, const char *name, size_t len)
{
    op_strmap_entry *p = op_strmap_find(&c->params, name, len);
    return p ? p->value : NULL;
}

/* Adds name=value unless name is already set (defines win over defaults, earlier over later). */
static op_status param_add(xml_ctx *c, const char *name, const char *value)
{
    if (param_get(c, name, strlen(name)))
        return OP_OK;
    char *v = strdup(value);
    op_strmap_entry *p = v ? op_strmap_add(&c->params, name) : NULL;
    if (!p) {
        free(v);
        return nomem(c);
    }
    p->value = v;
    return OP_OK;
}

static int ident_char(int ch, int first)
{
    return isalpha(ch) || ch == '_' || (!first && isdigit(ch));
}

/* Replaces every $name in value by the parameter's value (an undefined one is an error) and
 * every $$ by one $, counting the result against attribute-bytes before it is grown. */
static op_status substitute(xml_ctx *c, xmlNode *e, const char *attr, const char *value, char **out)
{
    size_t cap = strlen(value) + 1, n = 0;
    long long room = c->lim->attribute_bytes - c->attribute_bytes;
    char *buf = malloc(cap);
    if (!buf)
        return nomem(c);
    for (const char *p = value; *p;) {
        const char *piece = p;
        size_t len = 1;
        if (*p == '$' && p[1] == '$') {
            p += 2; /* piece: the first '$' */
        } else if (*p == '$' && ident_char((unsigned char)p[1], 1)) {
            size_t k = 1;
            while (ident_char((unsigned char)p[k], 0))
                k++;
            piece = param_get(c, p + 1, k - 1);
            if (!piece) {
                free(buf);
                return elem_error(c, e,
                                  "attribute %s: undefined parameter '%.*s' (give -D %.*s=VALUE "
                                  "or a <default name=\"%.*s\" value=\"...\"/>)",
                                  attr, (int)k, p, (int)k - 1, p + 1, (int)k - 1, p + 1);
            }
            len = strlen(piece);
            p += k;
        } else {
            p++;
        }
        if ((long long)(n + len) > room) {
            free(buf);
            return elem_error(c, e, "attribute %s: the attribute values after $parameter "
                              "expansion add up to more than the limit of %lld bytes "
                              "(attribute-bytes; raise it with --limit attribute-bytes=VALUE)",
                              attr, c->lim->attribute_bytes);
        }
        if (n + len + 1 > cap) {
            while (n + len + 1 > cap)
                cap *= 2;
            char *nb = realloc(buf, cap);
            if (!nb) {
                free(buf);
                return nomem(c);
            }
            buf = nb;
        }
        memcpy(buf + n, piece, len);
        n += len;
    }
    buf[n] = '\0';
    c->attribute_bytes += (long long)n;
    *out = buf;
    return OP_OK;
}

/* ---------------------------------------------------------------- attributes */

/* Every attribute of e must be in allowed (NULL-terminated). Namespaced ones are ignored. */
static op_status check_attrs(xml_ctx *c, xmlNode *e, const char *const *allowed)
{
    for (xmlAttr *a = e->properties; a; a = a->next) {
        if (a->ns)
            continue;
        int ok = 0;
        for (int i = 0; allowed[i] && !ok; i++)
            ok = strcmp((const char *)a->name, allowed[i]) == 0;
        if (!ok)
            return elem_error(c, e, "unexpected attribute '%s'", (const char *)a->name);
    }
    return OP_OK;
}

/* The attribute's value after $name substitution, malloc'd, or NULL when absent (an error
 * when required). */
static op_status get_attr(xml_ctx *c, xmlNode *e, const char *name, int required, char **out)
{
    *out = NULL;
    xmlAttr *a = xmlHasNsProp(e, (const xmlChar *)name, NULL);
    if (!a) {
        if (required)
            return elem_error(c, e, "missing attribute '%s'", name);
        return OP_OK;
    }
    const char *raw = attr_text(a);
    if (!raw)
        return elem_error(c, e, "attribute %s: entity references (&name;) are not supported; "
                                "use a $parameter",
                          name);
    return substitute(c, e, name, raw, out);
}

/* ---------------------------------------------------------------- numbers */

/* Reads attribute "name" (required or not) into *out as the Mitsuba 0.6 name of what the
 * file's dialect spells (dialect.h); *spelled gets the name as written when that differs (else
 * NULL). Both malloc'd; a name spelled in the other dialect is an error. */
static op_status get_name(xml_ctx *c, xmlNode *e, int required, char **out, char **spelled)
{
    *spelled = NULL;
    op_status st = get_attr(c, e, "name", required, out);
    if (st != OP_OK || !*out)
        return st;
    char canon[256], hint[256];
    int r = op_dialect_param_name(c->dialect, *out, canon, sizeof canon, hint, sizeof hint);
    if (r == -2) {
        st = elem_error(c, e, "name '%.60s...' is too long", *out);
    } else if (r == -1) {
        st = elem_error(c, e, "'%s' is how %s spells a parameter, but this file declares a %s "
                        "scene (version attribute of <scene>)%s%s%s", *out,
                        op_dialect_label(c->dialect == OP_DIALECT_MITSUBA_3 ? OP_DIALECT_MITSUBA_0
                                                                             : OP_DIALECT_MITSUBA_3),
                        op_dialect_label(c->dialect), hint[0] ? ": write '" : "", hint,
                        hint[0] ? "', or declare the other version" : "");
    } else if (strcmp(canon, *out) != 0) {
        *spelled = *out;
        *out = strdup(canon);
        if (!*out)
            st = nomem(c);
    }
    if (st != OP_OK) {
        free(*out);
        free(*spelled);
        *out = *spelled = NULL;
    }
    return st;
}

static int parse_double(const char *s, double *out)
{
    char *end;
    while (isspace((unsigned char)*s))
        s++;
    double v;
    if (!op_scan_double(s, &end, &v))
        return 0;
    while (isspace((unsigned char)*end))
        end++;
    if (*end)
        return 0;
    *out = v;
    return 1;
}

/* Numbers separated by commas and/or white space; returns how many (at most max), or -1 when
 * a token is not a number or there are more than max. */
static int parse_list(const char *s, double *out, int max)
{
    int n = 0;
    const char *p = s;
    for (;;) {
        while (isspace((unsigned char)*p))
            p++;
        if (!*p)
            return n;
        if (n == max)
            return -1;
        char *end;
        if (!op_scan_double(p, &end, &out[n]))
            return -1;
        n++;
        p = end;
        while (isspace((unsigned char)*p))
            p++;
        if (*p == ',') {
            p++;
            while (isspace((unsigned char)*p))
                p++;
            if (!*p)
                return -1; /* trailing comma */
        } else if (*p && !isspace((unsigned char)p[-1])) {
            return -1; /* "1x" */
        }
    }
}

static op_status attr_double(xml_ctx *c, xmlNode *e, const char *name, double def, double *out)
{
    char *s;
    op_status st = get_attr(c, e, name, 0, &s);
    if (st != OP_OK)
        return st;
    *out = def;
    if (s && !parse_double(s, out))
        st = elem_error(c, e, "attribute %s: bad number '%s'", name, s);
    free(s);
    return st;
}

/* Reads "x, y, z" from attribute name (required when def is NULL). */
static op_status attr_vec3(xml_ctx *c, xmlNode *e, const char *name, const double *def,
                           double out[3], int *present)
{
    char *s;
    op_status st = get_attr(c, e, name, def == NULL, &s);
    if (st != OP_OK)
        return st;
    if (present)
        *present = s != NULL;
    if (!s) {
        /* get_attr fails for an absent attribute unless a default was given. */
        if (def)
            memcpy(out, def, 3 * sizeof(double));
        else
            memset(out, 0, 3 * sizeof(double));
        return OP_OK;
    }
    if (parse_list(s, out, 3) != 3)
        st = elem_error(c, e, "attribute %s: expected three numbers 'x, y, z', got '%s'", name, s);
    free(s);
    return st;
}

/* x, y and z attributes (each defaulting to def) or value="x, y, z"; not both. */
static op_status attr_xyz(xml_ctx *c, xmlNode *e, double def, double out[3], int *any)
{
    static const char *axes[3] = {"x", "y", "z"};
    int have_xyz = 0;
    op_status st;
    for (int i = 0; i < 3; i++) {
        have_xyz |= xmlHasNsProp(e, (const xmlChar *)axes[i], NULL) != NULL;
        if ((st = attr_double(c, e, axes[i], def, &out[i])) != OP_OK)
            return st;
    }
    if (xmlHasNsProp(e, (const xmlChar *)"value", NULL)) {
        if (have_xyz)
            return elem_error(c, e, "give either x, y, z or value, not both");
        if ((st = attr_vec3(c, e, "value", NULL, out, NULL)) != OP_OK)
            return st;
        have_xyz = 1;
    }
    if (any)
        *any = have_xyz;
    return OP_OK;
}

/* ---------------------------------------------------------------- ids */

static op_strmap_entry *id_find(xml_ctx *c, const char *id)
{
    return op_strmap_find(&c->ids, id, strlen(id));
}

/* Registers id (not yet taken: callers check with id_find) for node defined at file:line. */
static op_status id_insert(xml_ctx *c, const char *id, op_node *node, const char *file, int line)
{
    op_strmap_entry *e = op_strmap_add(&c->ids, id);
    if (!e)
        return nomem(c);
    e->ptr = node;
    e->file = file;
    e->line = line;
    return OP_OK;
}

static op_status pending_add(xml_ctx *c, pending **arr, int *n, int *cap, op_node *parent,
                             int index, const char *id, const char *as, int line)
{
    if (!op_array_grow((void **)arr, cap, *n, sizeof **arr))
        return nomem(c);
    pending *p = &(*arr)[*n];
    memset(p, 0, sizeof *p);
    p->parent = parent;
    p->index = index;
    p->id = strdup(id);
    p->as = as ? strdup(as) : NULL;
    p->file = c->file;
    p->line = line;
    if (!p->id || (as && !p->as)) {
        free(p->id);
        free(p->as);
        return nomem(c);
    }
    (*n)++;
    return OP_OK;
}

/* ---------------------------------------------------------------- values */

typedef enum elem_class {
    EL_UNKNOWN,
    EL_OBJECT,
    EL_VALUE,
    EL_TRANSFORM,
    EL_TRANSFORM_OP,
    EL_REF,
    EL_INCLUDE,
    EL_ALIAS,
    EL_DEFAULT,
    EL_PATH,
    EL_SCENE
} elem_class;

static elem_class classify(const char *name)
{
    static const char *objects[] = {"shape",      "bsdf",   "emitter", "sensor",  "film",
                                    "sampler",    "rfilter", "integrator", "texture",
                                    "subsurface", "medium", "phase",   "volume", NULL};
    static const char *values[] = {"float", "integer", "boolean", "string",    "point",
                                   "vector", "rgb",    "srgb",    "spectrum", "blackbody", NULL};
    static const char *ops[] = {"translate", "rotate", "scale", "matrix", "lookat", "lookAt", NULL};
    for (int i = 0; objects[i]; i++)
        if (strcmp(name, objects[i]) == 0)
            return EL_OBJECT;
    for (int i = 0; values[i]; i++)
        if (strcmp(name, values[i]) == 0)
            return EL_VALUE;
    for (int i = 0; ops[i]; i++)
        if (strcmp(name, ops[i]) == 0)
            return EL_TRANSFORM_OP;
    if (strcmp(name, "transform") == 0)
        return EL_TRANSFORM;
    if (strcmp(name, "ref") == 0)
        return EL_REF;
    if (strcmp(name, "include") == 0)
        return EL_INCLUDE;
    if (strcmp(name, "alias") == 0)
        return EL_ALIAS;
    if (strcmp(name, "default") == 0)
        return EL_DEFAULT;
    if (strcmp(name, "path") == 0)
        return EL_PATH;
    if (strcmp(name, "scene") == 0)
        return EL_SCENE;
    return EL_UNKNOWN;
}

static int blank(const xmlChar *s)
{
    for (; s && *s; s++)
        if (!isspace(*s))
            return 0;
    return 1;
}

/* Value elements hold nothing but white space and comments. */
static op_status check_empty(xml_ctx *c, xmlNode *e)
{
    for (xmlNode *k = e->children; k; k = k->next) {
        if (k->type == XML_ELEMENT_NODE)
            return elem_error(c, e, "unexpected element <%s> inside it", (const char *)k->name);
        if ((k->type == XML_TEXT_NODE && !blank(k->content)) || k->type == XML_CDATA_SECTION_NODE)
            return elem_error(c, e, "unexpected text inside it");
        if (k->type == XML_ENTITY_REF_NODE)
            return elem_error(c, e, "entity references are not supported");
    }
    return OP_OK;
}

/* One transform operation, returned as the matrix to multiply on the left. */
static op_status transform_op(xml_ctx *c, xmlNode *e, op_matrix4 *m)
{
    const char *tag = (const char *)e->name;
    op_status st;
    if ((st = check_empty(c, e)) != OP_OK)
        return st;
    if (strcmp(tag, "translate") == 0) {
        static const char *const ok[] = {"x", "y", "z", "value", NULL};
        double v[3];
        if ((st = check_attrs(c, e, ok)) != OP_OK || (st = attr_xyz(c, e, 0.0, v, NULL)) != OP_OK)
            return st;
        *m = op_matrix4_translate(v[0], v[1], v[2]);
    } else if (strcmp(tag, "scale") == 0) {
        static const char *const ok[] = {"x", "y", "z", "value", NULL};
        double v[3] = {1, 1, 1};
        if ((st = check_attrs(c, e, ok)) != OP_OK)
            return st;
        char *s;
        if ((st = get_attr(c, e, "value", 0, &s)) != OP_OK)
            return st;
        int n = s ? parse_list(s, v, 3) : 0;
        if (s && n == 1)
            v[1] = v[2] = v[0];
        int has_xyz = xmlHasNsProp(e, (const xmlChar *)"x", NULL) ||
                      xmlHasNsProp(e, (const xmlChar *)"y", NULL) ||
                      xmlHasNsProp(e, (const xmlChar *)"z", NULL);
        if (s && (n != 1 && n != 3)) {
            st = elem_error(c, e, "attribute value: expected one or three numbers, got '%s'", s);
        } else if (s && has_xyz) {
            st = elem_error(c, e, "give either x, y, z or value, not both");
        } else if (!s) {
            if (!has_xyz)
                st = elem_error(c, e, "missing attribute 'value' (or x, y, z)");
            for (int i = 0; i < 3 && st == OP_OK; i++)
                st = attr_double(c, e, (const char *[]){"x", "y", "z"}[i], 1.0, &v[i]);
        }
        free(s);
        if (st != OP_OK)
            return st;
        *m = op_matrix4_scale(v[0], v[1], v[2]);
    } else if (strcmp(tag, "rotate") == 0) {
        static const char *const ok[] = {"x", "y", "z", "angle", "value", NULL};
        double axis[3], angle = 0.0;
        int any;
        if ((st = check_attrs(c, e, ok)) != OP_OK || (st = attr_xyz(c, e, 0.0, axis, &any)) != OP_OK)
            return st;
        char *s;
        if ((st = get_attr(c, e, "angle", 1, &s)) != OP_OK)
            return st;
        if (!parse_double(s, &angle))
            st = elem_error(c, e, "attribute angle: bad number '%s'", s);
        free(s);
        if (st != OP_OK)
            return st;
        if (!(axis[0] != 0 || axis[1] != 0 || axis[2] != 0))
            return elem_error(c, e, "the rotation axis (x, y, z) is zero");
        *m = op_matrix4_rotate(axis, angle);
    } else if (strcmp(tag, "matrix") == 0) {
        static const char *const ok[] = {"value", NULL};
        double v[16];
        char *s;
        if ((st = check_attrs(c, e, ok)) != OP_OK || (st = get_attr(c, e, "value", 1, &s)) != OP_OK)
            return st;
        int n = parse_list(s, v, 16);
        if (n != 16)
            st = elem_error(c, e, "attribute value: expected 16 numbers (row-major 4x4), got '%s'", s);
        free(s);
        if (st != OP_OK)
            return st;
        for (int i = 0; i < 16; i++)
            m->m[i / 4][i % 4] = v[i];
    } else { /* lookat, lookAt */
        static const char *const ok[] = {"origin", "target", "up", NULL};
        double o[3], t[3], u[3];
        static const double zero[3] = {0, 0, 0};
        int has_up;
        if ((st = check_attrs(c, e, ok)) != OP_OK ||
            (st = attr_vec3(c, e, "origin", NULL, o, NULL)) != OP_OK ||
            (st = attr_vec3(c, e, "target", NULL, t, NULL)) != OP_OK ||
            (st = attr_vec3(c, e, "up", zero, u, &has_up)) != OP_OK)
            return st;
        if (!op_matrix4_lookat(o, t, has_up ? u : NULL, m))
            return elem_error(c, e, "degenerate look-at: target equals origin, or up is zero or "
                                    "parallel to the viewing direction");
    }
    return OP_OK;
}

static op_status parse_transform(xml_ctx *c, xmlNode *e, op_matrix4 *out)
{
    *out = op_matrix4_identity();
    for (xmlNode *k = e->children; k; k = k->next) {
        if (k->type == XML_TEXT_NODE && !blank(k->content))
            return elem_error(c, e, "unexpected text inside it");
        if (k->type == XML_CDATA_SECTION_NODE || k->type == XML_ENTITY_REF_NODE)
            return elem_error(c, e, "unexpected content inside it");
        if (k->type != XML_ELEMENT_NODE)
            continue;
        if (classify((const char *)k->name) != EL_TRANSFORM_OP)
            return elem_error(c, k, "not a transform operation (translate, rotate, scale, "
                                    "matrix, lookat)");
        op_matrix4 m;
        op_status st = transform_op(c, k, &m);
        if (st != OP_OK)
            return st;
        *out = op_matrix4_mul(&m, out);
    }
    if (!op_matrix4_is_finite(out))
        return elem_error(c, e, "the composed transform is not finite");
    return OP_OK;
}

/* Parses a colour value ("r, g, b", "v" or "#rrggbb"); srgb decodes the numbers. */
static op_status parse_rgb(xml_ctx *c, xmlNode *e, const char *s, int srgb, double rgb[3])
{
    const char *p = s;
    while (isspace((unsigned char)*p))
        p++;
    if (*p == '#') {
        char hex[8] = {0};
        size_t n = strlen(p);
        while (n > 0 && isspace((unsigned char)p[n - 1]))
            n--;
        if (n == 7)
            memcpy(hex, p, 7);
        if (!op_color_parse_hex(hex, rgb))
            return elem_error(c, e, "bad colour '%s': expected #rrggbb", s);
        return OP_OK;
    }
    int n = parse_list(s, rgb, 3);
    if (n == 1)
        rgb[1] = rgb[2] = rgb[0];
    else if (n != 3)
        return elem_error(c, e, "bad colour '%s': expected 'r, g, b', one value, or #rrggbb", s);
    if (srgb)
        for (int i = 0; i < 3; i++)
            rgb[i] = op_srgb_to_linear(rgb[i]);
    return OP_OK;
}

/* Reads a value element (float ... blackbody, transform) into a new property of parent. */
static op_status value_element(xml_ctx *c, xmlNode *e, op_node *parent, elem_class cls)
{
    const char *tag = (const char *)e->name;
    char *name = NULL, *spelled = NULL, *value = NULL;
    op_status st = get_name(c, e, 1, &name, &spelled);
    if (st != OP_OK)
        return st;
    op_prop *prev = op_node_prop(parent, name);
    if (prev) {
        st = elem_error(c, e, "parameter '%s' is given twice (first at %s:%d)",
                        spelled ? spelled : name, prev->file, prev->line);
        free(name);
        free(spelled);
        return st;
    }
    int line = (int)xmlGetLineNo(e);
    op_prop tmp;
    memset(&tmp, 0, sizeof tmp);
    if (cls == EL_TRANSFORM) {
        static const char *const ok[] = {"name", NULL};
        tmp.kind = OP_PROP_TRANSFORM;
        if ((st = check_attrs(c, e, ok)) == OP_OK)
            st = parse_transform(c, e, &tmp.value.xf);
    } else if ((st = check_empty(c, e)) != OP_OK) {
        /* reported */
    } else if (strcmp(tag, "float") == 0 || strcmp(tag, "integer") == 0 ||
               strcmp(tag, "boolean") == 0 || strcmp(tag, "string") == 0) {
        static const char *const ok[] = {"name", "value", NULL};
        if ((st = check_attrs(c, e, ok)) == OP_OK)
            st = get_attr(c, e, "value", 1, &value);
        if (st != OP_OK) {
            /* reported */
        } else if (tag[0] == 'f') {
            tmp.kind = OP_PROP_FLOAT;
            if (!parse_double(value, &tmp.value.f))
                st = elem_error(c, e, "bad number '%s'", value);
        } else if (tag[0] == 'i') {
            tmp.kind = OP_PROP_INTEGER;
            const char *p = value;
            while (isspace((unsigned char)*p))
                p++;
            char *end;
            errno = 0;
            long long v = strtoll(p, &end, 10);
            while (end != p && isspace((unsigned char)*end))
                end++;
            if (end == p || *end || errno == ERANGE)
                st = elem_error(c, e, "bad integer '%s'", value);
            tmp.value.i = v;
        } else if (tag[0] == 'b') {
            /* Mitsuba 0.6 takes only these spellings; Mitsuba 2/3 any letter case ("False") */
            int (*same)(const char *, const char *) =
                c->dialect == OP_DIALECT_MITSUBA_3 ? strcasecmp : strcmp;
            tmp.kind = OP_PROP_BOOLEAN;
            if (same(value, "true") == 0)
                tmp.value.b = 1;
            else if (same(value, "false") == 0)
                tmp.value.b = 0;
            else
                st = elem_error(c, e, "bad boolean '%s': expected true or false", value);
        } else {
            tmp.kind = OP_PROP_STRING;
            tmp.value.s = value; /* moved into the property below */
            value = NULL;
        }
    } else if (strcmp(tag, "point") == 0 || strcmp(tag, "vector") == 0) {
        static const char *const ok[] = {"name", "x", "y", "z", "value", NULL};
        tmp.kind = tag[0] == 'p' ? OP_PROP_POINT : OP_PROP_VECTOR;
        if ((st = check_attrs(c, e, ok)) == OP_OK)
            st = attr_xyz(c, e, 0.0, tmp.value.v, NULL);
    } else if (strcmp(tag, "rgb") == 0 || strcmp(tag, "srgb") == 0) {
        static const char *const ok[] = {"name", "value", "intent", NULL};
        tmp.kind = OP_PROP_COLOR;
        if ((st = check_attrs(c, e, ok)) == OP_OK && (st = get_attr(c, e, "value", 1, &value)) == OP_OK)
            st = parse_rgb(c, e, value, tag[0] == 's', tmp.value.v);
    } else if (strcmp(tag, "spectrum") == 0) {
        static const char *const ok[] = {"name", "value", "filename", "intent", NULL};
        char *fname = NULL;
        tmp.kind = OP_PROP_COLOR;
        if ((st = check_attrs(c, e, ok)) == OP_OK && (st = get_attr(c, e, "value", 0, &value)) == OP_OK &&
            (st = get_attr(c, e, "filename", 0, &fname)) == OP_OK) {
            op_error sub = {0};
            /* Mitsuba 0.6's RGB build reads every spectrum plainly, Mitsuba 3 an emitter's;
             * Mitsuba 3's constant emitter spectrum is the equal-energy white, scaled */
            int emitter = strcmp(parent->tag, "emitter") == 0;
            op_spectrum_reading how = c->dialect == OP_DIALECT_MITSUBA_0 || emitter
                                          ? OP_SPECTRUM_PLAIN
                                          : OP_SPECTRUM_REFLECTANCE;
            if ((value != NULL) == (fname != NULL)) {
                st = elem_error(c, e, "give exactly one of value and filename");
            } else if (value) {
                if (op_color_parse_spectrum(value, how, tmp.value.v, &sub) != OP_OK)
                    st = elem_error(c, e, "%s", sub.message);
                else if (emitter && c->dialect == OP_DIALECT_MITSUBA_3 && !strchr(value, ':') &&
                         tmp.value.v[0] == tmp.value.v[1] && tmp.value.v[1] == tmp.value.v[2]) {
                    double e_white[3], one[3] = {1.0, 1.0, 1.0};
                    op_color_xyz_to_rgb(one, e_white);
                    for (int k = 0; k < 3; k++)
                        tmp.value.v[k] *= e_white[k];
                }
            } else {
                char *path = op_desc_tree_resolve(c->tree, c->file, fname);
                if (!path)
                    st = nomem(c);
                else if (op_color_read_spectrum_file(path, how, tmp.value.v, &sub) != OP_OK)
                    st = elem_error(c, e, "%s", sub.message);
                free(path);
            }
        }
        free(fname);
    } else { /* blackbody */
        static const char *const ok[] = {"name", "temperature", "scale", "intent", NULL};
        double scale = 1.0, kelvin;
        tmp.kind = OP_PROP_COLOR;
        if ((st = check_attrs(c, e, ok)) == OP_OK &&
            (st = get_attr(c, e, "temperature", 1, &value)) == OP_OK &&
            (st = attr_double(c, e, "scale", 1.0, &scale)) == OP_OK) {
            size_t n = strlen(value);
            while (n > 0 && isspace((unsigned char)value[n - 1]))
                n--;
            if (n > 0 && (value[n - 1] == 'K' || value[n - 1] == 'k'))
                n--;
            value[n] = '\0';
            op_error sub = {0};
            if (!parse_double(value, &kelvin))
                st = elem_error(c, e, "bad temperature '%s': expected kelvins such as 5000K", value);
            else if (op_color_blackbody(kelvin, tmp.value.v, &sub) != OP_OK)
                st = elem_error(c, e, "%s", sub.message);
            for (int i = 0; i < 3; i++)
                tmp.value.v[i] *= scale;
        }
    }
    if (st == OP_OK) {
        op_prop *p = op_desc_prop_add(parent, name, tmp.kind, c->file, line);
        if (!p) {
            st = nomem(c);
        } else {
            p->value = tmp.value;
            tmp.value.s = NULL; /* now owned by the tree */
            p->spelled = spelled;
            spelled = NULL;
        }
    }
    if (tmp.kind == OP_PROP_STRING)
        free(tmp.value.s);
    free(name);
    free(spelled);
    free(value);
    return st;
}

/* ---------------------------------------------------------------- files */

static op_status process_children(xml_ctx *c, xmlNode *xparent, op_node *parent);
static op_status parse_file(xml_ctx *c, const char *path, xmlNode *from, op_node *parent);

static op_status object_element(xml_ctx *c, xmlNode *e, op_node *parent)
{
    static const char *const ok[] = {"type", "id", "name", NULL};
    char *type = NULL, *id = NULL, *name = NULL, *spelled = NULL;
    op_status st;
    if ((st = check_attrs(c, e, ok)) == OP_OK && (st = get_attr(c, e, "type", 1, &type)) == OP_OK &&
        (st = get_attr(c, e, "id", 0, &id)) == OP_OK && (st = get_name(c, e, 0, &name, &spelled)) == OP_OK) {
        if (!*type)
            st = elem_error(c, e, "empty type");
        else if (id && !*id)
            st = elem_error(c, e, "empty id");
    }
    op_strmap_entry *old = st == OP_OK && id ? id_find(c, id) : NULL;
    if (old)
        st = elem_error(c, e, "duplicate id '%s' (first defined at %s:%d)", id, old->file, old->line);
    op_node *n = NULL;
    if (st == OP_OK) {
        n = op_desc_node_new(c->tree, (const char *)e->name, type, id, name, c->file,
                             (int)xmlGetLineNo(e));
        if (!n || op_desc_child_add(parent, n, NULL) < 0)
            st = nomem(c);
        else
            n->dialect = c->dialect;
    }
    if (st == OP_OK && id)
        st = id_insert(c, id, n, c->file, (int)xmlGetLineNo(e));
    free(type);
    free(id);
    free(name);
    free(spelled);
    if (st == OP_OK)
        st = process_children(c, e, n);
    return st;
}

static op_status process_element(xml_ctx *c, xmlNode *e, op_node *parent)
{
    const char *tag = (const char *)e->name;
    int in_scene = parent == op_desc_tree_root(c->tree);
    op_status st;
    switch (classify(tag)) {
    case EL_OBJECT:
        return object_element(c, e, parent);
    case EL_VALUE:
    case EL_TRANSFORM:
        if (in_scene)
            return elem_error(c, e, "a parameter must be inside an object, not directly in <scene>");
        return value_element(c, e, parent, classify(tag));
    case EL_TRANSFORM_OP:
        return elem_error(c, e, "<%s> is only allowed inside <transform>", tag);
    case EL_REF: {
        static const char *const ok[] = {"id", "name", NULL};
        char *id = NULL, *name = NULL, *spelled = NULL;
        if (in_scene)
            return elem_error(c, e, "<ref> must be inside an object");
        if ((st = check_attrs(c, e, ok)) != OP_OK || (st = check_empty(c, e)) != OP_OK ||
            (st = get_attr(c, e, "id", 1, &id)) != OP_OK ||
            (st = get_name(c, e, 0, &name, &spelled)) != OP_OK) {
            free(id);
            return st;
        }
        free(spelled);
        int index = op_desc_child_add(parent, NULL, name);
        st = index < 0 ? nomem(c)
                       : pending_add(c, &c->refs, &c->nrefs, &c->cap_refs, parent, index, id, NULL,
                                     (int)xmlGetLineNo(e));
        free(id);
        free(name);
        return st;
    }
    case EL_ALIAS: {
        static const char *const ok[] = {"id", "as", NULL};
        char *id = NULL, *as = NULL;
        if ((st = check_attrs(c, e, ok)) == OP_OK && (st = check_empty(c, e)) == OP_OK &&
            (st = get_attr(c, e, "id", 1, &id)) == OP_OK && (st = get_attr(c, e, "as", 1, &as)) == OP_OK)
            st = pending_add(c, &c->aliases, &c->naliases, &c->cap_aliases, NULL, 0, id, as,
                             (int)xmlGetLineNo(e));
        free(id);
        free(as);
        return st;
    }
    case EL_INCLUDE: {
        static const char *const ok[] = {"filename", NULL};
        char *fname = NULL;
        if ((st = check_attrs(c, e, ok)) == OP_OK && (st = check_empty(c, e)) == OP_OK &&
            (st = get_attr(c, e, "filename", 1, &fname)) == OP_OK) {
            if (++c->includes > c->lim->include_count) {
                free(fname);
                return elem_error(c, e, "more than %lld <include> elements are read (include-count, "
                                  "nested ones counted each time; raise it with --limit "
                                  "include-count=VALUE)", c->lim->include_count);
            }
            char *path = op_desc_tree_resolve(c->tree, c->file, fname);
            st = path ? parse_file(c, path, e, parent) : nomem(c);
            free(path);
        }
        free(fname);
        return st;
    }
    case EL_DEFAULT: /* read before the walk, by read_defaults */
        return OP_OK;
    case EL_PATH: {
        static const char *const ok[] = {"value", NULL};
        char *value = NULL;
        if (!in_scene)
            return elem_error(c, e, "<path> must be directly inside <scene>");
        if ((st = check_attrs(c, e, ok)) == OP_OK && (st = check_empty(c, e)) == OP_OK &&
            (st = get_attr(c, e, "value", 1, &value)) == OP_OK) {
            /* relative to the folder of the file that holds it */
            char *dir = *value ? op_path_beside(c->file, value) : NULL;
            if (!*value)
                st = elem_error(c, e, "empty value");
            else if (!dir || op_desc_tree_add_folder(c->tree, dir) != 0)
                st = nomem(c);
            free(dir);
        }
        free(value);
        return st;
    }
    case EL_SCENE:
        return elem_error(c, e, "<scene> may only be the root element of a file");
    case EL_UNKNOWN:
        break;
    }
    return elem_error(c, e, "unknown element <%s>", tag);
}

static op_status process_children(xml_ctx *c, xmlNode *xparent, op_node *parent)
{
    for (xmlNode *k = xparent->children; k; k = k->next) {
        op_status st = OP_OK;
        switch (k->type) {
        case XML_ELEMENT_NODE:
            st = process_element(c, k, parent);
            break;
        case XML_TEXT_NODE:
            if (!blank(k->content))
                st = elem_error(c, xparent, "unexpected text '%.40s'", (const char *)k->content);
            break;
        case XML_CDATA_SECTION_NODE:
            st = elem_error(c, xparent, "unexpected CDATA section");
            break;
        case XML_ENTITY_REF_NODE:
            st = elem_error(c, xparent, "entity references are not supported");
            break;
        default: /* comments, processing instructions */
            break;
        }
        if (st != OP_OK)
            return st;
    }
    return OP_OK;
}

/* The first libxml2 error of a parse, captured instead of printed. */
typedef struct xml_capture {
    int have;
    int nomem; /* libxml2 could not allocate: out of memory, not bad input */
    int line;
    char message[512];
} xml_capture;

#if LIBXML_VERSION >= 21200
static void on_xml_error(void *data, const xmlError *e)
#else
static void on_xml_error(void *data, xmlErrorPtr e)
#endif
{
    xmlParserCtxtPtr p = data;
    xml_capture *cap = p ? p->_private : NULL;
    if (cap && e && e->code == XML_ERR_NO_MEMORY)
        cap->nomem = 1;
    if (!cap || cap->have || !e || e->level < XML_ERR_ERROR)
        return;
    cap->have = 1;
    cap->line = e->line;
    snprintf(cap->message, sizeof cap->message, "%s", e->message ? e->message : "malformed XML");
    size_t n = strlen(cap->message);
    while (n > 0 && (cap->message[n - 1] == '\n' || cap->message[n - 1] == ' '))
        cap->message[--n] = '\0';
}

/* Reads a scene or included file whole (op_file_read: regular files only, MAX_SCENE_BYTES at
 * most), its size checked first against what include-bytes leaves; a failure to read an
 * include names the <include> element. */
static op_status read_whole(xml_ctx *c, const char *path, xmlNode *from, char **buf, size_t *len)
{
    int fd;
    uint64_t size = 0;
    op_status st = op_file_open(path, &fd, &size, c->err);
    if (st == OP_OK) {
        close(fd);
        if (size > (uint64_t)(c->lim->include_bytes - c->include_bytes)) {
            char what[200];
            snprintf(what, sizeof what, "with its %llu bytes the scene file and its includes "
                     "add up to more than the limit of %lld bytes (include-bytes; raise it with "
                     "--limit include-bytes=VALUE)", (unsigned long long)size,
                     c->lim->include_bytes);
            return from ? elem_error(c, from, "%s", what)
                        : op_error_set(c->err, OP_ERR_INPUT, "%s: %s", path, what);
        }
        st = op_file_read(path, MAX_SCENE_BYTES, buf, len, c->err);
    }
    if (st != OP_OK && from && c->err)
        elem_error(c, from, "cannot read included file: %s", c->err->message);
    if (st != OP_OK && c->err)
        c->err->status = st;
    if (st == OP_OK)
        c->include_bytes += (long long)*len;
    return st;
}

/* Reads <scene version="X.Y.Z"> into c->dialect: 0.5 and 0.6 silently, other 0.x and 1.x as
 * 0.6 with a warning, 2.x and 3.x as Mitsuba 3 (dialect.h). */
static op_status check_version(xml_ctx *c, xmlNode *root)
{
    static const char *const ok[] = {"version", NULL};
    char *v;
    op_status st;
    if ((st = check_attrs(c, root, ok)) != OP_OK || (st = get_attr(c, root, "version", 1, &v)) != OP_OK)
        return st;
    int unusual = 0;
    if (op_dialect_from_version(v, &c->dialect, &unusual) != 0)
        st = elem_error(c, root, "bad version '%s': expected major.minor.patch of a Mitsuba "
                        "release (0.4 to 0.6, 2.x or 3.x), such as 0.6.0 or 3.0.0", v);
    else if (unusual)
        op_log(OP_LOG_WARN, "%s:%ld: <scene>: version %s is not 0.5 or 0.6; reading it as 0.6",
               c->file, xmlGetLineNo(root), v);
    free(v);
    return st;
}

/* Reads every <default> of the file (in <scene> or, as Mitsuba's schema allows, inside an
 * object) before the walk, so that a parameter may be used above its <default>. */
static op_status read_defaults(xml_ctx *c, xmlNode *parent)
{
    op_status st = OP_OK;
    for (xmlNode *k = parent->children; k && st == OP_OK; k = k->next) {
        if (k->type != XML_ELEMENT_NODE)
            continue;
        if (xmlStrcmp(k->name, (const xmlChar *)"default") != 0) {
            if (classify((const char *)k->name) == EL_OBJECT)
                st = read_defaults(c, k);
            continue;
        }
        static const char *const ok[] = {"name", "value", NULL};
        char *name = NULL, *value = NULL;
        if ((st = check_attrs(c, k, ok)) == OP_OK && (st = check_empty(c, k)) == OP_OK &&
            (st = get_attr(c, k, "name", 1, &name)) == OP_OK &&
            (st = get_attr(c, k, "value", 1, &value)) == OP_OK) {
            if (!*name || !ident_char((unsigned char)name[0], 1))
                st = elem_error(c, k, "bad parameter name '%s'", name);
            else
                st = param_add(c, name, value);
        }
        free(name);
        free(value);
    }
    return st;
}

/* Reads path and walks its <scene> into parent (the root, or the node holding <include>). */
static op_status parse_file(xml_ctx *c, const char *path, xmlNode *from, op_node *parent)
{
    if (c->depth == MAX_INCLUDE_DEPTH)
        return elem_error(c, from, "includes are nested more than %d deep", MAX_INCLUDE_DEPTH);
    char *canon = realpath(path, NULL);
    if (canon) {
        for (int i = 0; i < c->depth; i++)
            if (strcmp(c->stack[i], canon) == 0) {
                free(canon);
                return elem_error(c, from, "include cycle: '%s' is already being read", path);
            }
    }
    char *buf = NULL;
    size_t len = 0;
    op_status st = read_whole(c, path, from, &buf, &len);
    if (st != OP_OK) {
        free(canon);
        return st;
    }
    if (!canon) { /* readable but not resolvable: cannot take part in a cycle check */
        canon = strdup(path);
        if (!canon) {
            free(buf);
            return nomem(c);
        }
    }
    const char *saved_file = c->file;
    op_dialect saved_dialect = c->dialect;
    const char *file = op_desc_tree_file(c->tree, path);
    if (!file) {
        free(buf);
        free(canon);
        return nomem(c);
    }
    c->stack[c->depth++] = canon;
    c->file = file;

    xml_capture cap = {0};
    xmlParserCtxtPtr px = xmlNewParserCtxt();
    xmlDocPtr doc = NULL;
    if (!px) {
        st = nomem(c);
        goto out;
    }
    px->_private = &cap;
    px->sax->serror = on_xml_error;
    px->sax->warning = NULL;
    px->sax->error = NULL;
    px->vctxt.error = NULL;
    px->vctxt.warning = NULL;
    if (len > INT_MAX) {
        st = op_error_set(c->err, OP_ERR_INPUT, "%s: scene file too large", path);
        goto out;
    }
    doc = xmlCtxtReadMemory(px, buf, (int)len, path, NULL,
                            XML_PARSE_NONET | XML_PARSE_BIG_LINES | XML_PARSE_NOWARNING);
    if (!doc || !px->wellFormed || cap.have) {
        if (cap.nomem)
            st = nomem(c);
        else if (cap.have)
            st = op_error_set(c->err, OP_ERR_INPUT, "%s:%d: malformed XML: %s", path, cap.line,
                              cap.message);
        else
            st = op_error_set(c->err, OP_ERR_INPUT, "%s: malformed XML", path);
        goto out;
    }
    xmlNode *root = xmlDocGetRootElement(doc);
    if (!root || xmlStrcmp(root->name, (const xmlChar *)"scene") != 0) {
        st = root ? elem_error(c, root, "the root element must be <scene version=\"0.6.0\">")
                  : op_error_set(c->err, OP_ERR_INPUT, "%s: no root element", path);
        goto out;
    }
    if ((st = check_version(c, root)) != OP_OK)
        goto out;
    if (!from) { /* the main file: the root node is this <scene> */
        parent->file = file;
        parent->line = (int)xmlGetLineNo(root);
        parent->dialect = c->dialect;
    }
    st = read_defaults(c, root);
    if (st == OP_OK)
        st = process_children(c, root, parent);
out:
    if (doc)
        xmlFreeDoc(doc);
    if (px)
        xmlFreeParserCtxt(px);
    free(buf);
    free(c->stack[--c->depth]);
    c->file = saved_file;
    c->dialect = saved_dialect;
    return st;
}

/* ---------------------------------------------------------------- entry point */

static op_status resolve(xml_ctx *c)
{
    for (int i = 0; i < c->naliases; i++) {
        pending *a = &c->aliases[i];
        op_strmap_entry *t = id_find(c, a->id);
        if (!t)
            return op_error_set(c->err, OP_ERR_INPUT, "%s:%d: <alias id=\"%s\" as=\"%s\">: unknown id '%s'",
                                a->file, a->line, a->id, a->as, a->id);
        op_strmap_entry *old = id_find(c, a->as);
        if (old)
            return op_error_set(c->err, OP_ERR_INPUT,
                                "%s:%d: <alias id=\"%s\" as=\"%s\">: duplicate id '%s' (first defined at %s:%d)",
                                a->file, a->line, a->id, a->as, a->as, old->file, old->line);
        op_status st = id_insert(c, a->as, t->ptr, a->file, a->line);
        if (st != OP_OK)
            return st;
    }
    for (int i = 0; i < c->nrefs; i++) {
        pending *r = &c->refs[i];
        op_strmap_entry *t = id_find(c, r->id);
        if (!t)
            return op_error_set(c->err, OP_ERR_INPUT, "%s:%d: <ref id=\"%s\">: unknown id '%s'",
                                r->file, r->line, r->id, r->id);
        r->parent->children[r->index] = t->ptr;
    }
    op_node *cyc = op_desc_tree_find_cycle(c->tree);
    if (cyc)
        return op_node_error(cyc, c->err, OP_ERR_INPUT,
                             "reference cycle: this object contains itself through <ref>");
    return OP_OK;
}

op_status op_desc_parse(const char *path, const op_define *defines, int ndefines,
                        const op_scene_limits *limits, op_node **root, op_error *err)
{
    return op_desc_parse_in(path, NULL, 0, defines, ndefines, limits, root, err);
}

/* Adds the search folders, each checked to be a directory, after any <path> folder: a <path>
 * is prepended as it is read, so these go in first, last one first. */
static op_status add_search_folders(xml_ctx *c, const char *const *folders, int nfolders)
{
    if (nfolders < 0 || (nfolders > 0 && !folders))
        return op_error_set(c->err, OP_ERR_INPUT, "bad search folder list");
    for (int i = nfolders - 1; i >= 0; i--) {
        struct stat sb;
        if (!folders[i] || !*folders[i])
            return op_error_set(c->err, OP_ERR_INPUT, "empty search folder name");
        if (stat(folders[i], &sb) != 0)
            return op_error_set(c->err, OP_ERR_INPUT, "search folder %s: %s", folders[i],
                                strerror(errno));
        if (!S_ISDIR(sb.st_mode))
            return op_error_set(c->err, OP_ERR_INPUT, "search folder %s: not a folder",
                                folders[i]);
        if (op_desc_tree_add_folder(c->tree, folders[i]) != 0)
            return nomem(c);
    }
    return OP_OK;
}

op_status op_desc_parse_in(const char *path, const char *const *folders, int nfolders,
                           const op_define *defines, int ndefines, const op_scene_limits *limits,
                           op_node **root, op_error *err)
{
    *root = NULL;
    xmlInitParser(); /* idempotent; see libxml2's threading notes */
    op_scene_limits defaults;
    op_scene_limits_init(&defaults);
    xml_ctx c;
    memset(&c, 0, sizeof c);
    c.err = err;
    c.lim = limits ? limits : &defaults;
    c.file = path;
    c.tree = op_desc_tree_new();
    op_status st = c.tree ? add_search_folders(&c, folders, nfolders) : nomem(&c);
    for (int i = 0; i < ndefines && st == OP_OK; i++) {
        if (!defines[i].name || !*defines[i].name || !defines[i].value)
            st = op_error_set(err, OP_ERR_INPUT, "bad parameter definition (-D name=value)");
        else
            st = param_add(&c, defines[i].name, defines[i].value);
    }
    if (st == OP_OK)
        st = parse_file(&c, path, NULL, op_desc_tree_root(c.tree));
    if (st == OP_OK)
        st = resolve(&c);

    op_strmap_free(&c.params);
    op_strmap_free(&c.ids);
    for (int i = 0; i < c.nrefs; i++)
        free(c.refs[i].id);
    free(c.refs);
    for (int i = 0; i < c.naliases; i++) {
        free(c.aliases[i].id);
        free(c.aliases[i].as);
    }
    free(c.aliases);
    if (st != OP_OK) {
        op_desc_tree_free(c.tree);
        return st;
    }
    *root = op_desc_tree_root(c.tree);
    return OP_OK;
}
