/* scene_desc.h - a parsed scene description: the tree of Mitsuba-style objects (scene, shape,
 * bsdf, emitter, sensor, film, sampler, rfilter, integrator, texture, subsurface, ...) with their
 * typed properties, before any of it is turned into geometry or lights.
 *
 * scene_xml.c builds it from XML (libxml2); the scene builder reads it through the getters
 * below, which mark each property used, so that op_desc_report_unused() can name every
 * property and object that nothing consumed. Every node and property remembers its file and
 * line so that errors can name them.
 *
 * Ownership: op_desc_parse() returns a tree that op_desc_free() releases whole. A node reached
 * through <ref id> is shared: it appears as a child of each referring node but is owned (and
 * freed) once, by the tree. */
#ifndef OP_SCENE_DESC_H
#define OP_SCENE_DESC_H

#include "opaline.h"
#include "opaline_render.h" /* op_scene_limits */
#include "math/transform.h"      /* op_matrix4 */
#include "scene/dialect.h"

typedef enum op_prop_kind {
    OP_PROP_FLOAT,
    OP_PROP_INTEGER,
    OP_PROP_BOOLEAN,
    OP_PROP_STRING,
    OP_PROP_POINT,
    OP_PROP_VECTOR,
    OP_PROP_COLOR,     /* rgb, srgb (already linearized), spectrum (reduced to linear RGB) */
    OP_PROP_TRANSFORM  /* <transform name=...>: the composed 4x4 matrix */
} op_prop_kind;

typedef struct op_prop {
    char *name;    /* the Mitsuba 0.6 name the builders ask for (dialect.h) */
    char *spelled; /* the name as the file wrote it, when that differs (a Mitsuba 3 name); or
                    * NULL. Messages name the property by op_prop_name() */
    op_prop_kind kind;
    union {
        double f;       /* FLOAT */
        long long i;    /* INTEGER */
        int b;          /* BOOLEAN */
        char *s;        /* STRING */
        double v[3];    /* POINT, VECTOR, COLOR (linear RGB) */
        op_matrix4 xf;  /* TRANSFORM */
    } value;
    const char *file; /* owned by the tree */
    int line;
    int used;
} op_prop;

typedef struct op_node op_node;
struct op_node {
    char *tag;   /* element name: "scene", "shape", "bsdf", "emitter", ... */
    char *type;  /* the type attribute ("obj", "diffuse", ...); NULL for <scene> */
    char *id;    /* may be NULL */
    char *name;  /* the name attribute of a nested object (e.g. a named texture); may be NULL */
    const char *file;
    int line;
    op_dialect dialect; /* of the file that defines the node */
    op_prop *props;
    int nprops;
    op_node **children; /* in document order; referenced nodes appear where the <ref> was */
    int nchildren;
    int used;           /* set by the consumer (op_node_mark_used) when it takes the object */
    char **child_names; /* per child: the name it has here (a <ref name=...> or its own name
                         * attribute), or NULL; see op_node_child_name */
};

/* A -D name=value override of a <default name="..." value="..."/>. */
typedef struct op_define {
    const char *name;
    const char *value;
} op_define;

/* Parses path (following <include>, resolving <ref>, substituting $name from defines and
 * <default>) within limits' include-bytes, include-count and attribute-bytes (NULL: the
 * defaults). Errors are OP_ERR_INPUT with "file:line: element: what is wrong". */
op_status op_desc_parse(const char *path, const op_define *defines, int ndefines,
                        const op_scene_limits *limits, op_node **root, op_error *err);
/* op_desc_parse with search folders: the files the scene names are looked for, after its own
 * folder, the working directory and its <path> folders, in folders[0..nfolders) in order. A
 * folder that is not a directory is OP_ERR_INPUT naming it. */
op_status op_desc_parse_in(const char *path, const char *const *folders, int nfolders,
                           const op_define *defines, int ndefines, const op_scene_limits *limits,
                           op_node **root, op_error *err);

/* strtod for numbers in scene text: 1 and *out when s starts with a finite number (a denormal
 * or one that underflows to zero is accepted as strtod rounds it), *end after it; 0 otherwise. */
int op_scan_double(const char *s, char **end, double *out);
void op_desc_free(op_node *root);

/* Property getters. Each marks the property used and returns def when it is absent. A present
 * property of the wrong kind is an error (OP_ERR_INPUT naming file, line, element and name);
 * integers are accepted where a float is asked for. */
op_status op_node_float(op_node *n, const char *name, double def, double *out, op_error *err);
op_status op_node_int(op_node *n, const char *name, long long def, long long *out, op_error *err);
op_status op_node_bool(op_node *n, const char *name, int def, int *out, op_error *err);
/* The string stays owned by the tree. */
op_status op_node_string(op_node *n, const char *name, const char *def, const char **out,
                         op_error *err);
/* Accepts POINT or VECTOR. A NULL def means (0, 0, 0) (also for op_node_color). */
op_status op_node_vec3(op_node *n, const char *name, const double def[3], double out[3],
                       op_error *err);
/* Accepts COLOR, or a FLOAT/INTEGER as a grey. */
op_status op_node_color(op_node *n, const char *name, const double def[3], double out[3],
                        op_error *err);
/* Identity when absent. */
op_status op_node_transform(op_node *n, const char *name, op_matrix4 *out, op_error *err);
/* Whether a property of that name exists (does not mark it used). */
int op_node_has(const op_node *n, const char *name);

/* Navigation. The name child i has in n: the name attribute of the <ref> that put it there,
 * else its own name attribute, else NULL. */
const char *op_node_child_name(const op_node *n, int i);
/* The k-th (from 0) child whose tag is tag (any tag when tag is NULL), or NULL. */
op_node *op_node_child(const op_node *n, const char *tag, int k);
/* How many children have that tag (all when tag is NULL). */
int op_node_count(const op_node *n, const char *tag);
/* Marks an object consumed, so op_desc_report_unused does not name it. */
void op_node_mark_used(op_node *n);
/* The file rel names, found as Mitsuba finds it: as given when absolute; else the first that
 * exists of rel in the folder of the file that defines n, in the main scene file's folder, in
 * the working directory, and in each <path> folder (the last one given first); when none
 * exists, the first of these (so that a message names where it was expected). Malloc'd, NULL
 * when out of memory. */
char *op_node_resolve(const op_node *n, const char *rel);
/* Writes <tag type="..." id="..."> describing n into buf; returns buf. */
const char *op_node_describe(const op_node *n, char *buf, size_t cap);
/* Sets err to status with "file:line: <tag type=...>: message" for node n; returns status.
 * For the scene builder's errors about an object. */
op_status op_node_error(const op_node *n, op_error *err, op_status status, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* The same for one property of n. */
op_status op_prop_error(const op_node *n, const op_prop *p, op_error *err, op_status status,
                        const char *fmt, ...) __attribute__((format(printf, 5, 6)));
/* The property named name (not marked used), or NULL. */
op_prop *op_node_prop(const op_node *n, const char *name);

/* The name of p as its file spells it. */
const char *op_prop_name(const op_prop *p);

/* 1 when the builders render objects of element tag with this type, else 0. */
typedef int (*op_type_known_fn)(const char *tag, const char *type);

/* Logs a warning "file:line: <tag type=...>: unused parameter 'x'" (or unused object, adding
 * when known, if not NULL, says its type is not one opaline renders) for everything not marked
 * used; returns the count. */
int op_desc_report_unused(const op_node *root, op_type_known_fn known);

/* 1 when name is one of names (NULL-terminated), else 0. */
int op_name_listed(const char *const *names, const char *name);
/* names (NULL-terminated) joined by ", " into buf (n bytes, truncated); returns buf. */
const char *op_names_join(const char *const *names, char *buf, size_t n);

/* For the scene builder's functions that return op_status: returns the failed call's status
 * (as recorded in err; OP_ERR_INPUT when err is NULL) unless call returned OP_OK. */
#define GET_OR_FAIL(call)                                                                          \
    do {                                                                                           \
        if ((call) != OP_OK)                                                                       \
            return err ? err->status : OP_ERR_INPUT;                                               \
    } while (0)

/* Makes element n of the array *arr (of *cap elements of elem bytes) writable: when n >= *cap,
 * reallocates it to the smallest doubling of *cap (8 at first) above n and zero-fills the new
 * elements. Returns 0, with *arr and *cap unchanged, when n is negative, when out of memory or
 * when the new size would overflow an int count or a size_t byte size. The scene reader's and builder's growing
 * arrays all go through it. */
int op_array_grow(void **arr, int *cap, int n, size_t elem);

/* A table of strings (open addressing, never more than half full): the scene reader's
 * parameters and ids and the builder's shared meshes, each looked up in constant time. An
 * entry's key and value are owned by the table; the other fields are the caller's. */
typedef struct op_strmap_entry {
    char *key;
    char *value;      /* a parameter's value, or NULL */
    void *ptr;        /* an id's object */
    const char *file; /* where the key was defined */
    int line;
    int index;        /* the caller's number for the key */
} op_strmap_entry;
typedef struct op_strmap {
    op_strmap_entry *slots;
    size_t n, cap;
} op_strmap;

/* The entry whose key is the len bytes at key, or NULL. */
op_strmap_entry *op_strmap_find(const op_strmap *m, const char *key, size_t len);
/* A new entry for key (not yet in m: callers check with op_strmap_find), its key copied and
 * the rest zero; NULL when out of memory. Entries move when the table grows. */
op_strmap_entry *op_strmap_add(op_strmap *m, const char *key);
/* Frees the keys, the values and the table (m may be all zero). */
void op_strmap_free(op_strmap *m);

#endif
