/* material_lookup.h - where a <subsurface>'s material file is: an .opm path, or a preset name
 * and the folders searched for it, in order. */
#ifndef OP_MATERIAL_LOOKUP_H
#define OP_MATERIAL_LOOKUP_H

#include <stddef.h>

#include "opaline.h"

/* Finds a subsurface material: an .opm path (relative to scene_dir; not checked here, since
 * opening it says what is wrong with it) or a preset name looked up in scene_dir, each folder
 * of OPALINE_PRESETS_PATH, the installed presets (share/opaline/presets beside the running
 * program's bin folder), then the build tree's presets folder. Writes the file into out; the
 * error lists every folder searched. */
op_status op_resolve_material(const char *name, const char *scene_dir, char *out, size_t n,
                              op_error *err);

#endif
