/* scene_desc.c - the scene tree: ownership, typed getters, and the unused-parameter report.
 * Building it from XML is scene_xml.c's job. */
#include "scene/scene_desc_internal.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Every node is allocated as a desc_node so that the tree can keep traversal marks and
 * capacities beside the public fields. */
typedef struct desc_node {
    op_node n; /* first: an op_node * is a desc_node * */
    const op_desc_tree *tree;
    int mark;  /* traversal state: 0 unvisited, 1 on the stack, 2 done */
    int cap_props, cap_children;
} desc_node;

struct op_desc_tree {
    desc_node root; /* first: the root op_node * is the tree * */
    desc_node **nodes;
    int nnodes, cap_nodes;
    char **files;
    int nfiles, cap_files;
    char **folders; /* <path> folders, in the order a name is looked up in them */
    int nfolders, cap_folders;
};

static char *dup_or_null(const char *s, int *fail)
{
    if (!s)
        return NULL;
    char *d = strdup(s);
    if (!d)
        *fail = 1;
    return d;
}

int op_scan_double(const char *s, char **end, double *out)
{
    /* strtod sets ERANGE for a result below DBL_MIN too, yet returns the denormal (or zero)
     * nearest the text: only an infinite result (overflow, or "inf") is refused */
    double v = strtod(s, end);
    if (*end == s || !isfinite(v))
        return 0;
    *out = v;
    return 1;
}

/* Grows *arr (of elem-sized items) so that index n fits; returns 0 when out of memory. */
int op_array_grow(void **arr, int *cap, int n, size_t elem)
{
    if (n < 0)
        return 0;
    if (n < *cap)
        return 1;
    if (n >= INT_MAX / 2 || elem == 0)
        return 0;
    int c = *cap > 0 ? *cap : 8;
    while (c <= n) /* c <= n < INT_MAX / 2: doubling cannot overflow */
        c *= 2;
    if ((size_t)c > SIZE_MAX / elem)
        return 0;
    void *p = realloc(*arr, (size_t)c * elem);
    if (!p)
        return 0;
    memset((char *)p + (size_t)*cap * elem, 0, (size_t)(c - *cap) * elem);
    *arr = p;
    *cap = c;
    return 1;
}

op_desc_tree *op_desc_tree_new(void)
{
    op_desc_tree *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;
    t->root.n.tag = strdup("scene");
    if (!t->root.n.tag) {
        free(t);
        return NULL;
    }
    t->root.n.used = 1;
    t->root.tree = t;
    return t;
}

op_node *op_desc_tree_root(op_desc_tree *t)
{
    return &t->root.n;
}

static void node_free_fields(op_node *n)
{
    free(n->tag);
    free(n->type);
    free(n->id);
    free(n->name);
    for (int i = 0; i < n->nprops; i++) {
        free(n->props[i].name);
        free(n->props[i].spelled);
        if (n->props[i].kind == OP_PROP_STRING)
            free(n->props[i].value.s);
    }
    free(n->props);
    for (int i = 0; i < n->nchildren; i++)
        free(n->child_names[i]);
    free(n->child_names);
    free(n->children);
}

void op_desc_tree_free(op_desc_tree *t)
{
    if (!t)
        return;
    for (int i = 0; i < t->nnodes; i++) {
        node_free_fields(&t->nodes[i]->n);
        free(t->nodes[i]);
    }
    free(t->nodes);
    node_free_fields(&t->root.n);
    for (int i = 0; i < t->nfiles; i++)
        free(t->files[i]);
    free(t->files);
    for (int i = 0; i < t->nfolders; i++)
        free(t->folders[i]);
    free(t->folders);
    free(t);
}

void op_desc_free(op_node *root)
{
    op_desc_tree_free((op_desc_tree *)root);
}

const char *op_desc_tree_file(op_desc_tree *t, const char *path)
{
    for (int i = 0; i < t->nfiles; i++)
        if (strcmp(t->files[i], path) == 0)
            return t->files[i];
    if (!op_array_grow((void **)&t->files, &t->cap_files, t->nfiles, sizeof *t->files))
        return NULL;
    char *d = strdup(path);
    if (!d)
        return NULL;
    t->files[t->nfiles++] = d;
    return d;
}

op_node *op_desc_node_new(op_desc_tree *t, const char *tag, const char *type, const char *id,
                          const char *name, const char *file, int line)
{
    if (!op_array_grow((void **)&t->nodes, &t->cap_nodes, t->nnodes, sizeof *t->nodes))
        return NULL;
    desc_node *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    int fail = 0;
    d->n.tag = dup_or_null(tag, &fail);
    d->n.type = dup_or_null(type, &fail);
    d->n.id = dup_or_null(id, &fail);
    d->n.name = dup_or_null(name, &fail);
    d->n.file = file;
    d->n.line = line;
    d->tree = t;
    if (fail) {
        node_free_fields(&d->n);
        free(d);
        return NULL;
    }
    t->nodes[t->nnodes++] = d;
    return &d->n;
}

op_prop *op_desc_prop_add(op_node *n, const char *name, op_prop_kind kind, const char *file,
                          int line)
{
    desc_node *d = (desc_node *)n;
    if (!op_array_grow((void **)&n->props, &d->cap_props, n->nprops, sizeof *n->props))
        return NULL;
    op_prop *p = &n->props[n->nprops];
    memset(p, 0, sizeof *p);
    p->name = strdup(name);
    if (!p->name)
        return NULL;
    p->kind = kind;
    p->file = file;
    p->line = line;
    if (kind == OP_PROP_STRING)
        p->value.s = NULL;
    n->nprops++;
    return p;
}

int op_desc_child_add(op_node *parent, op_node *child, const char *name)
{
    desc_node *d = (desc_node *)parent;
    if (parent->nchildren >= d->cap_children) {
        /* Both arrays always have cap_children entries. */
        int nc = d->cap_children ? d->cap_children * 2 : 4;
        op_node **c = realloc(parent->children, (size_t)nc * sizeof *c);
        if (!c)
            return -1;
        parent->children = c;
        char **names = realloc(parent->child_names, (size_t)nc * sizeof *names);
        if (!names)
            return -1;
        parent->child_names = names;
        d->cap_children = nc;
    }
    char *nm = NULL;
    if (name && !(nm = strdup(name)))
        return -1;
    parent->children[parent->nchildren] = child;
    parent->child_names[parent->nchildren] = nm;
    return parent->nchildren++;
}

/* Depth-first search for a back edge; marks: 1 on the stack, 2 finished. */
static op_node *cycle_from(op_node *n)
{
    desc_node *d = (desc_node *)n;
    d->mark = 1;
    for (int i = 0; i < n->nchildren; i++) {
        op_node *c = n->children[i];
        if (!c)
            continue;
        int m = ((desc_node *)c)->mark;
        if (m == 1)
            return c;
        if (m == 0) {
            op_node *r = cycle_from(c);
            if (r)
                return r;
        }
    }
    d->mark = 2;
    return NULL;
}

static void clear_marks(op_desc_tree *t)
{
    t->root.mark = 0;
    for (int i = 0; i < t->nnodes; i++)
        t->nodes[i]->mark = 0;
}

op_node *op_desc_tree_find_cycle(op_desc_tree *t)
{
    clear_marks(t);
    op_node *r = cycle_from(&t->root.n);
    clear_marks(t);
    return r;
}

/* ---------------------------------------------------------------- describing */

const char *op_node_describe(const op_node *n, char *buf, size_t cap)
{
    size_t k = (size_t)snprintf(buf, cap, "<%s", n->tag);
    if (n->type && k < cap)
        k += (size_t)snprintf(buf + k, cap - k, " type=\"%s\"", n->type);
    if (n->id && k < cap)
        k += (size_t)snprintf(buf + k, cap - k, " id=\"%s\"", n->id);
    if (n->name && k < cap)
        k += (size_t)snprintf(buf + k, cap - k, " name=\"%s\"", n->name);
    if (k < cap)
        snprintf(buf + k, cap - k, ">");
    return buf;
}

op_status op_node_error(const op_node *n, op_error *err, op_status status, const char *fmt, ...)
{
    if (!err)
        return status;
    char msg[768], desc[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return op_error_set(err, status, "%s:%d: %s: %s", n->file ? n->file : "?", n->line,
                        op_node_describe(n, desc, sizeof desc), msg);
}

op_status op_prop_error(const op_node *n, const op_prop *p, op_error *err, op_status status,
                        const char *fmt, ...)
{
    if (!err)
        return status;
    char msg[768], desc[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return op_error_set(err, status, "%s:%d: %s: parameter '%s': %s", p->file ? p->file : "?",
                        p->line, op_node_describe(n, desc, sizeof desc), op_prop_name(p), msg);
}

/* ---------------------------------------------------------------- navigation */

const char *op_node_child_name(const op_node *n, int i)
{
    if (i < 0 || i >= n->nchildren)
        return NULL;
    if (n->child_names[i])
        return n->child_names[i];
    return n->children[i] ? n->children[i]->name : NULL;
}

op_node *op_node_child(const op_node *n, const char *tag, int k)
{
    for (int i = 0; i < n->nchildren; i++) {
        op_node *c = n->children[i];
        if (c && (!tag || strcmp(c->tag, tag) == 0) && k-- == 0)
            return c;
    }
    return NULL;
}

int op_node_count(const op_node *n, const char *tag)
{
    int count = 0;
    for (int i = 0; i < n->nchildren; i++)
        count += n->children[i] && (!tag || strcmp(n->children[i]->tag, tag) == 0);
    return count;
}

void op_node_mark_used(op_node *n)
{
    n->used = 1;
}

static char *join(const char *dir, size_t dl, const char *rel)
{
    size_t rl = strlen(rel);
    char *out = malloc(dl + rl + 2);
    if (!out)
        return NULL;
    memcpy(out, dir, dl);
    out[dl] = '/';
    memcpy(out + dl + 1, rel, rl + 1);
    return out;
}

static size_t folder_len(const char *file)
{
    const char *slash = file ? strrchr(file, '/') : NULL;
    return slash ? (size_t)(slash - file) : 0;
}

char *op_desc_tree_resolve(const op_desc_tree *t, const char *file, const char *rel)
{
    if (rel[0] == '/')
        return strdup(rel);
    const char *main_file = t->root.n.file;
    const char *dirs[2]; /* the scene's folders, before the search folders */
    size_t lens[2];
    int nc = 0;
    dirs[nc] = file, lens[nc] = folder_len(file), nc++;
    if (main_file && (folder_len(main_file) != lens[0] ||
                      (file && strncmp(main_file, file, lens[0]) != 0)))
        dirs[nc] = main_file, lens[nc] = folder_len(main_file), nc++;
    char *first = NULL;
    /* the working directory last, as Mitsuba 0.6's and 3's resolvers hold it */
    for (int i = 0; i <= nc + t->nfolders; i++) {
        int cwd = i == nc + t->nfolders;
        const char *dir = cwd ? "" : i < nc ? dirs[i] : t->folders[i - nc];
        size_t dl = cwd ? 0 : i < nc ? lens[i] : strlen(dir);
        char *cand = dl > 0 ? join(dir, dl, rel) : strdup(rel);
        if (!cand) {
            free(first);
            return NULL;
        }
        if (access(cand, F_OK) == 0) {
            free(first);
            return cand;
        }
        if (first)
            free(cand);
        else
            first = cand;
    }
    return first;
}

char *op_node_resolve(const op_node *n, const char *rel)
{
    return op_desc_tree_resolve(((const desc_node *)n)->tree, n->file, rel);
}

int op_desc_tree_add_folder(op_desc_tree *t, const char *folder)
{
    if (!op_array_grow((void **)&t->folders, &t->cap_folders, t->nfolders, sizeof *t->folders))
        return -1;
    char *f = strdup(folder);
    if (!f)
        return -1;
    /* a later <path> is searched first, as Mitsuba prepends it */
    memmove(t->folders + 1, t->folders, (size_t)t->nfolders * sizeof *t->folders);
    t->folders[0] = f;
    t->nfolders++;
    return 0;
}

/* ---------------------------------------------------------------- getters */

const char *op_prop_name(const op_prop *p)
{
    return p->spelled ? p->spelled : p->name;
}

op_prop *op_node_prop(const op_node *n, const char *name)
{
    for (int i = 0; i < n->nprops; i++)
        if (strcmp(n->props[i].name, name) == 0)
            return &n->props[i];
    return NULL;
}

int op_node_has(const op_node *n, const char *name)
{
    return op_node_prop(n, name) != NULL;
}

static const char *kind_name(op_prop_kind k)
{
    switch (k) {
    case OP_PROP_FLOAT: return "a float";
    case OP_PROP_INTEGER: return "an integer";
    case OP_PROP_BOOLEAN: return "a boolean";
    case OP_PROP_STRING: return "a string";
    case OP_PROP_POINT: return "a point";
    case OP_PROP_VECTOR: return "a vector";
    case OP_PROP_COLOR: return "a colour";
    case OP_PROP_TRANSFORM: return "a transform";
    }
    return "a value";
}

/* Finds name, marks it used, and checks its kind against the accepted ones. *found is NULL
 * when absent. */
static op_status lookup(op_node *n, const char *name, const op_prop_kind *ok, int nok,
                        const char *wanted, op_prop **found, op_error *err)
{
    op_prop *p = op_node_prop(n, name);
    *found = p;
    if (!p)
        return OP_OK;
    p->used = 1;
    for (int i = 0; i < nok; i++)
        if (p->kind == ok[i])
            return OP_OK;
    *found = NULL;
    return op_prop_error(n, p, err, OP_ERR_INPUT, "is %s, expected %s", kind_name(p->kind), wanted);
}

op_status op_node_float(op_node *n, const char *name, double def, double *out, op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_FLOAT, OP_PROP_INTEGER};
    op_prop *p;
    op_status st = lookup(n, name, ok, 2, "a float", &p, err);
    if (st == OP_OK)
        *out = !p ? def : p->kind == OP_PROP_FLOAT ? p->value.f : (double)p->value.i;
    return st;
}

op_status op_node_int(op_node *n, const char *name, long long def, long long *out, op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_INTEGER};
    op_prop *p;
    op_status st = lookup(n, name, ok, 1, "an integer", &p, err);
    if (st == OP_OK)
        *out = p ? p->value.i : def;
    return st;
}

op_status op_node_bool(op_node *n, const char *name, int def, int *out, op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_BOOLEAN};
    op_prop *p;
    op_status st = lookup(n, name, ok, 1, "a boolean", &p, err);
    if (st == OP_OK)
        *out = p ? p->value.b : def;
    return st;
}

op_status op_node_string(op_node *n, const char *name, const char *def, const char **out,
                         op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_STRING};
    op_prop *p;
    op_status st = lookup(n, name, ok, 1, "a string", &p, err);
    if (st == OP_OK)
        *out = p ? p->value.s : def;
    return st;
}

op_status op_node_vec3(op_node *n, const char *name, const double def[3], double out[3],
                       op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_POINT, OP_PROP_VECTOR};
    op_prop *p;
    op_status st = lookup(n, name, ok, 2, "a point or vector", &p, err);
    static const double zero[3] = {0, 0, 0};
    if (st == OP_OK)
        memmove(out, p ? p->value.v : def ? def : zero, 3 * sizeof(double));
    return st;
}

op_status op_node_color(op_node *n, const char *name, const double def[3], double out[3],
                        op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_COLOR, OP_PROP_FLOAT, OP_PROP_INTEGER};
    op_prop *p;
    op_status st = lookup(n, name, ok, 3, "a colour", &p, err);
    if (st != OP_OK)
        return st;
    static const double zero[3] = {0, 0, 0};
    if (!p)
        memmove(out, def ? def : zero, 3 * sizeof(double));
    else if (p->kind == OP_PROP_COLOR)
        memmove(out, p->value.v, 3 * sizeof(double));
    else
        out[0] = out[1] = out[2] = p->kind == OP_PROP_FLOAT ? p->value.f : (double)p->value.i;
    return OP_OK;
}

op_status op_node_transform(op_node *n, const char *name, op_matrix4 *out, op_error *err)
{
    static const op_prop_kind ok[] = {OP_PROP_TRANSFORM};
    op_prop *p;
    op_status st = lookup(n, name, ok, 1, "a transform", &p, err);
    if (st == OP_OK)
        *out = p ? p->value.xf : op_matrix4_identity();
    return st;
}

/* ---------------------------------------------------------------- unused report */

static int report_node(op_node *n, op_type_known_fn known)
{
    desc_node *d = (desc_node *)n;
    char desc[256];
    d->mark = 2;
    if (!n->used) {
        int unknown = known && n->type && !known(n->tag, n->type);
        op_log(OP_LOG_WARN, "%s:%d: %s: unused object%s%s%s", n->file ? n->file : "?", n->line,
               op_node_describe(n, desc, sizeof desc),
               unknown ? ", of a type opaline does not render (unknown " : "",
               unknown ? n->tag : "", unknown ? " type)" : "");
        return 1;
    }
    int count = 0;
    for (int i = 0; i < n->nprops; i++)
        if (!n->props[i].used) {
            op_log(OP_LOG_WARN, "%s:%d: %s: unused parameter '%s'",
                   n->props[i].file ? n->props[i].file : "?", n->props[i].line,
                   op_node_describe(n, desc, sizeof desc), op_prop_name(&n->props[i]));
            count++;
        }
    for (int i = 0; i < n->nchildren; i++)
        if (n->children[i] && ((desc_node *)n->children[i])->mark == 0)
            count += report_node(n->children[i], known);
    return count;
}

int op_desc_report_unused(const op_node *root, op_type_known_fn known)
{
    /* The marks are scratch space: the tree is logically unchanged. */
    op_desc_tree *t = (op_desc_tree *)root;
    clear_marks(t);
    int count = report_node(&t->root.n, known);
    clear_marks(t);
    return count;
}

int op_name_listed(const char *const *names, const char *name)
{
    for (int i = 0; names[i]; i++)
        if (strcmp(names[i], name) == 0)
            return 1;
    return 0;
}

const char *op_names_join(const char *const *names, char *buf, size_t n)
{
    size_t k = 0;
    buf[0] = '\0';
    for (int i = 0; names[i] && k < n; i++) {
        int w = snprintf(buf + k, n - k, "%s%s", i ? ", " : "", names[i]);
        if (w < 0)
            break;
        k += (size_t)w;
    }
    return buf;
}

static uint64_t hash_bytes(const char *s, size_t len)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a */
    for (size_t i = 0; i < len; i++)
        h = (h ^ (unsigned char)s[i]) * 1099511628211ull;
    return h;
}

op_strmap_entry *op_strmap_find(const op_strmap *m, const char *key, size_t len)
{
    if (!m->cap)
        return NULL;
    for (size_t i = hash_bytes(key, len) & (m->cap - 1);; i = (i + 1) & (m->cap - 1)) {
        const char *k = m->slots[i].key;
        if (!k)
            return NULL;
        if (strncmp(k, key, len) == 0 && k[len] == '\0')
            return &m->slots[i];
    }
}

op_strmap_entry *op_strmap_add(op_strmap *m, const char *key)
{
    if ((m->n + 1) * 2 > m->cap) {
        size_t nc = m->cap ? m->cap * 2 : 64;
        op_strmap_entry *grown = calloc(nc, sizeof *grown);
        if (!grown)
            return NULL;
        for (size_t i = 0; i < m->cap; i++)
            if (m->slots[i].key) {
                size_t j = hash_bytes(m->slots[i].key, strlen(m->slots[i].key)) & (nc - 1);
                while (grown[j].key)
                    j = (j + 1) & (nc - 1);
                grown[j] = m->slots[i];
            }
        free(m->slots);
        m->slots = grown;
        m->cap = nc;
    }
    size_t j = hash_bytes(key, strlen(key)) & (m->cap - 1);
    while (m->slots[j].key)
        j = (j + 1) & (m->cap - 1);
    if (!(m->slots[j].key = strdup(key)))
        return NULL;
    m->n++;
    return &m->slots[j];
}

void op_strmap_free(op_strmap *m)
{
    for (size_t i = 0; i < m->cap; i++) {
        free(m->slots[i].key);
        free(m->slots[i].value);
    }
    free(m->slots);
    memset(m, 0, sizeof *m);
}
