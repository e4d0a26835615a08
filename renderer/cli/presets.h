/* presets.h - where the renderer finds materials, for the programs that hand it scenes (the
 * Blender add-on, opaline-cluster): --find-material and --preset-folders (docs/rendering.md,
 * "Finding materials"). The search itself is the library's (op_find_material). */
#ifndef OP_PRESETS_H
#define OP_PRESETS_H

#include <stdio.h>

/* Exit code of --find-material for a name no folder holds (nor a path to a regular file). */
enum { OP_EXIT_NOT_FOUND = 3 };

/* Prints to f a line "searched FOLDER" per folder searched for the material name, as a scene
 * in scene_dir (NULL: the current folder) does, then "found FILE" when it is found. Returns
 * the exit code: 0 found, OP_EXIT_NOT_FOUND, 2 for a name that cannot be printed as one line,
 * 1 when f cannot be written. */
int op_print_material(FILE *f, const char *name, const char *scene_dir);
/* Prints to f the folders preset names are looked up in, one a line, scene_dir's first when
 * not NULL. Returns the exit code as op_print_material does. */
int op_print_preset_folders(FILE *f, const char *scene_dir);

#endif
