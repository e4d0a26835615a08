/* scene_desc_internal.h - how scene_xml.c builds the tree that scene_desc.c owns. */
#ifndef OP_SCENE_DESC_INTERNAL_H
#define OP_SCENE_DESC_INTERNAL_H

#include "scene/scene_desc.h"

typedef struct op_desc_tree op_desc_tree;

/* A tree holding only its root <scene> node; NULL when out of memory. */
op_desc_tree *op_desc_tree_new(void);
op_node *op_desc_tree_root(op_desc_tree *t);
/* Frees the tree and every node, property and string in it. Accepts NULL. */
void op_desc_tree_free(op_desc_tree *t);
/* A copy of path owned by the tree (one per distinct path), or NULL when out of memory. */
const char *op_desc_tree_file(op_desc_tree *t, const char *path);
/* A new node owned by the tree (not yet anyone's child); strings are copied, NULL allowed
 * except for tag. NULL when out of memory. */
op_node *op_desc_node_new(op_desc_tree *t, const char *tag, const char *type, const char *id,
                          const char *name, const char *file, int line);
/* Appends an unset property (name copied); NULL when out of memory. A STRING value must be
 * malloc'd: the tree frees it. */
op_prop *op_desc_prop_add(op_node *n, const char *name, op_prop_kind kind, const char *file,
                          int line);
/* Appends child (may be NULL for a placeholder filled in later) under the given name (copied,
 * may be NULL). Returns the child's index, or -1 when out of memory. */
int op_desc_child_add(op_node *parent, op_node *child, const char *name);
/* Appends a <path> folder (copied) to those names are looked up in; a later one is searched
 * first. -1 when out of memory. */
int op_desc_tree_add_folder(op_desc_tree *t, const char *folder);
/* rel as Mitsuba finds it (op_node_resolve) for a name written in file. */
char *op_desc_tree_resolve(const op_desc_tree *t, const char *file, const char *rel);
/* Finds a reference cycle among the nodes reachable from the root: returns a node on it, or
 * NULL when there is none. Placeholders must all be filled. */
op_node *op_desc_tree_find_cycle(op_desc_tree *t);

#endif
