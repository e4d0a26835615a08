/* scene_path.h - file names of a scene joined to its folder. */
#ifndef OP_SCENE_PATH_H
#define OP_SCENE_PATH_H

#include <stddef.h>

/* Writes dir + "/" + name into out (name alone when absolute or dir is empty), truncated to
 * n - 1 bytes. */
void op_path_join(char *out, size_t n, const char *dir, const char *name);

/* rel in the folder of file (rel itself when absolute or file has no folder); malloc'd, NULL
 * when out of memory. */
char *op_path_beside(const char *file, const char *rel);

#endif
