/*
 * opaline_render.h - the opaline renderer library.
 *
 * Loads a Mitsuba 0.5/0.6-style scene (XML) and path traces it, with opaline's measured
 * heterogeneous subsurface materials on shapes (<subsurface type="svd|tucker|kcta|nmf|raw">,
 * and the classical dipole, type="dipole"; see docs/subsurface-rendering.md).
 *
 * Use: op_scene_load() a scene, op_renderer_new() with options, op_renderer_render() it (as
 * many times as wanted), read op_renderer_image(), write it with op_scene_write_image(), free
 * both. Errors follow opaline.h: an op_status plus an op_error naming the file and line at fault.
 * A loaded scene is read-only while rendering; one renderer renders one scene at a time.
 * Rendering is deterministic: the same scene, sample count and seed give a bit-identical image
 * for any number of threads.
 */
#ifndef OPALINE_RENDER_H
#define OPALINE_RENDER_H

#include <stdatomic.h>

#include "opaline.h"
#include "opaline_image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct op_scene op_scene;
typedef struct op_scene_description op_scene_description;
typedef struct op_renderer op_renderer;

/* A -D name=value override of a scene's <default name="..." value="..."/>. */
typedef struct op_scene_define {
    const char *name;
    const char *value;
} op_scene_define;

/* What a scene may ask for, checked while it loads (so that --check and rendering agree): a
 * scene over a limit is refused with OP_ERR_INPUT naming the limit, before the work or the
 * memory it would take. docs/limits.md explains each one and its default. */
typedef struct op_scene_limits {
    double coordinate;      /* "coordinate": the largest |x|, |y|, |z| of any position (camera,
                               lights, shape vertices after toWorld), in scene units; single-
                               precision ray tracing has a spacing of coordinate * 2^-24 there */
    long long image_pixels; /* "image-pixels": the most pixels (width x height) of one texture
                               or environment map, checked from its header before decoding */
    int kernel;             /* "kernel": the largest kernel side K of a measured subsurface
                               material (the pre-pass costs K^2 per irradiance point) */
    long long sss_points;   /* "sss-points": the most irradiance points of all translucent
                               shapes together, after each shape's maxPoints cap */
    int sss_max_points;     /* "sss-max-points": the maxPoints (irradiance points of one shape,
                               a quality cap that warns when reached) of every <subsurface>
                               that sets none */
    long long include_bytes;   /* "include-bytes": the bytes of the scene file and of every file
                                  it includes, counted at each <include> (nested ones too) */
    long long include_count;   /* "include-count": the <include> elements read, nested ones
                                  counted each time their file is read */
    long long attribute_bytes; /* "attribute-bytes": the bytes of all attribute values after
                                  $parameter expansion, <default> values included */
    long long triangles;       /* "triangles": the triangles the scene stores (a mesh shared by
                                  instances once), checked before the acceleration structure */
    long long load_memory;     /* "load-memory": the bytes the scene is estimated to take once
                                  loaded (its triangles, as stored and in Embree's structures,
                                  and its images), checked as each mesh or image is read */
} op_scene_limits;

/* The defaults: coordinate 1e7, image-pixels 2^27 (16384 x 8192), kernel 255, sss-points 5e7,
 * sss-max-points 250000, include-bytes 2^30, include-count 100000, attribute-bytes 2^28,
 * triangles 1e8, load-memory 2^35 (32 GiB). */
void op_scene_limits_init(op_scene_limits *lim);
/* Sets one limit from "name=value" (a name above, a positive number within the limit's hard
 * range); anything else is OP_ERR_INPUT naming the known limits. */
op_status op_scene_limits_set(op_scene_limits *lim, const char *assignment, op_error *err);

/* Describes the scene at path without building it: parses it, builds its film, sampler, camera
 * and integrator, checks the limits that need no geometry, finds every file it names (meshes,
 * textures, environment maps, materials: opened and closed, so that a missing or unreadable
 * one is refused as op_scene_load would, and the run's record of inputs holds them all), counts
 * its shapes, emitters and translucent shapes and estimates the memory a build takes; reads no
 * mesh, opens no material, decodes no image, builds no acceleration structure. What a file's
 * content does wrong is found by op_scene_load only. limits NULL: the defaults; errors as
 * op_scene_load_limited's. */
op_status op_scene_describe(const char *path, const op_scene_define *defines, int ndefines,
                            const op_scene_limits *limits, op_scene_description **out,
                            op_error *err);
void op_scene_description_free(op_scene_description *d);

/* Parses and builds the scene at path (op_scene_describe, then geometry, acceleration
 * structure, materials: only what the scene uses), within the limits (NULL: the defaults). Bad
 * input (including a missing or unreadable file it names, and anything over a limit) gives
 * OP_ERR_INPUT or OP_ERR_FORMAT naming file:line; err may be NULL. */
op_status op_scene_load_limited(const char *path, const op_scene_define *defines, int ndefines,
                                const op_scene_limits *limits, op_scene **out, op_error *err);
/* op_scene_describe and op_scene_load_limited with search folders (Mitsuba's -a): a file the
 * scene names (mesh, image, include, spectrum) by a relative name is looked for beside the file
 * naming it, in the scene's folder, the working directory, the scene's <path> folders (the last
 * one first), then in folders[0..nfolders) in order. A folder that does not exist or is not a
 * directory is OP_ERR_INPUT naming it; folders may be NULL when nfolders is 0. */
op_status op_scene_describe_in(const char *path, const char *const *folders, int nfolders,
                               const op_scene_define *defines, int ndefines,
                               const op_scene_limits *limits, op_scene_description **out,
                               op_error *err);
op_status op_scene_load_in(const char *path, const char *const *folders, int nfolders,
                           const op_scene_define *defines, int ndefines,
                           const op_scene_limits *limits, op_scene **out, op_error *err);
/* op_scene_load_limited with the default limits. */
op_status op_scene_load(const char *path, const op_scene_define *defines, int ndefines,
                        op_scene **out, op_error *err);
void op_scene_free(op_scene *scene);

/* Called with each folder, in order; a non-zero return stops the walk. */
typedef int (*op_folder_fn)(void *user, const char *folder);
/* Walks the folders a material preset name (<subsurface material="NAME">) is looked up in, in
 * the order searched: scene_dir ("" for the current folder; NULL leaves the scene's folder
 * out), each folder of OPALINE_PRESETS_PATH, the installed presets (share/opaline/presets above
 * the running program's bin folder), then, for a renderer that is not installed (that folder
 * does not exist), the build tree's presets. Folders need not exist.
 * Fails only when out of memory. */
op_status op_preset_folders(const char *scene_dir, op_folder_fn each, void *user,
                            op_error *err);
/* Finds a subsurface material as a scene in scene_dir (NULL or "": the current folder) does:
 * an .opm path (relative to scene_dir; not checked here, since opening it says what is wrong
 * with it) as it is, a preset name in the first folder of op_preset_folders holding NAME.opm.
 * Writes the file into out (n bytes). each, when not NULL, is told every folder searched (its
 * return value is ignored). A name in no folder is OP_ERR_INPUT listing the folders. */
op_status op_find_material(const char *name, const char *scene_dir, op_folder_fn each,
                           void *user, char *out, size_t n, op_error *err);

/* What the scene's film asks for, and what the scene holds. Strings stay owned by the scene (or
 * the description). */
typedef struct op_scene_info {
    int width, height;        /* the image rendered (the crop window when there is one) */
    int full_width, full_height;
    int spp;                  /* the sampler's sampleCount */
    const char *film_type;    /* "hdrfilm", "ldrfilm" or "mfilm" */
    const char *film_filename;/* the film's filename, or NULL */
    const char *film_extension;/* its fileFormat's extension: ".exr", ".pfm", ".hdr", ".png" or
                                  ".m" (mfilm: a text matrix) */
    const char *integrator;   /* "path", "direct", "normals", ... */
    int shapes, emitters, subsurface_shapes;
    int triangles;            /* a description's: -1 when some shape reads a mesh file */
    int instances;            /* shapes that place a mesh file shared with others (one copy);
                                 -1 for a description */
    long long geometry_bytes; /* the scene's triangle data plus Embree's structures; -1 for a
                                 description */
    long long load_bytes;     /* the estimated peak memory of building the scene (in a process
                                 of its own): a description's estimate, from file sizes, mesh
                                 and image headers */
    const char *const *files; /* the files the scene names (meshes, textures, environment maps,
                                 materials), as resolved, each once, in the order the build
                                 reads them; not the scene file and its includes */
    int nfiles;
} op_scene_info;

void op_scene_get_info(const op_scene *scene, op_scene_info *info);
/* The same from a description: its film, sampler and counts, before building. */
void op_scene_description_get_info(const op_scene_description *d, op_scene_info *info);

/* Replaces the film's crop window (cropOffsetX/Y, cropWidth/Height) by the w x h pixels at
 * (x, y) of the full film, top-left origin: a render then computes only those pixels, each
 * exactly as in the full image. A window not inside the film is OP_ERR_INPUT. Call before
 * rendering. */
op_status op_scene_set_crop(op_scene *scene, int x, int y, int w, int h, op_error *err);

/* The same for a description (before building; what --estimate reports). */
op_status op_scene_description_set_crop(op_scene_description *d, int x, int y, int w, int h,
                                        op_error *err);
/* The description scene was built from (owned by scene): its film and what it names. */
const op_scene_description *op_scene_description_of(const op_scene *scene);

/* A finished tile: RGBA linear floats, rows from the top; x, y its top-left pixel in the image. */
typedef struct op_render_tile {
    int x, y, w, h;
    const float *rgba; /* w * h * 4 floats, valid during the callback only */
} op_render_tile;

/* Called once per finished tile, never concurrently with itself (the renderer serializes). */
typedef void (*op_tile_fn)(void *user, const op_render_tile *tile);

enum { OP_RENDER_TILE_SIZE = 32 }; /* the tiles' side unless op_render_options says */

typedef struct op_render_options {
    int threads;             /* worker threads; 0 = all cores */
    int spp;                 /* samples per pixel; 0 = the scene's sampler */
    int tile_size;           /* tile side in pixels; 0 = OP_RENDER_TILE_SIZE */
    uint64_t seed;           /* mixed into every random stream (default 0) */
    op_progress_fn progress; /* NULL: op_progress's own report on stderr */
    void *progress_user;
    op_tile_fn tile;         /* may be NULL */
    void *tile_user;
    atomic_int *cancel;      /* when non-NULL and set non-zero, rendering stops soon */
    const char *sss_cache;   /* NULL, or the subsurface pre-pass cache file: reused where its
                                key matches, (re)written when the pre-pass computed anything
                                (docs/subsurface-rendering.md, "Pre-pass cache") */
    int sss_cache_only;      /* with sss_cache: the pre-pass only (no camera pass, no image) */
} op_render_options;

/* The defaults: every field zero or NULL. */
void op_render_options_init(op_render_options *opt);

/* opt is copied; NULL means the defaults. Returns NULL when out of memory. */
op_renderer *op_renderer_new(const op_render_options *opt);
void op_renderer_free(op_renderer *r);

/* Renders scene into the renderer's image (RGBA, alpha = coverage). Returns OP_ERR_CANCELLED
 * when the cancel flag stopped it (in the subsurface pre-pass or between pixel rows of a tile):
 * the image then holds the finished tiles, op_render_stats.tiles_done of them (others black,
 * alpha 0). The scene must outlive the call only. */
op_status op_renderer_render(op_renderer *r, const op_scene *scene, op_error *err);

/* What the last render computed for its subsurface pre-pass (all zero before the first render
 * and for scenes without translucent shapes) and how long its camera pass took. The pre-pass computes only what camera paths
 * need: see docs/subsurface-rendering.md. */
typedef struct op_render_stats {
    long long sss_points;    /* irradiance points laid, on the translucent shapes the camera reaches */
    long long sss_sources;   /* points whose irradiance was computed */
    long long sss_receivers; /* points whose exitance was computed */
    long long sss_sources_reused, sss_receivers_reused; /* taken from the pre-pass cache */
    int sss_shapes_reached;  /* translucent shapes some camera segment reaches */
    int sss_shapes_capped;   /* of those, shapes given fewer irradiance points than they need:
                                capped at their maxPoints (each also warned) */
    double sss_seconds;      /* the pre-pass's wall time */
    double render_seconds;   /* the camera pass's wall time (after the pre-pass) */
    int tiles;               /* the image's tiles */
    int tiles_done;          /* tiles finished: all of them unless the render was cancelled */
} op_render_stats;

void op_renderer_get_stats(const op_renderer *r, op_render_stats *st);

/* The last rendered image (width * height * 4 floats), or NULL before the first render. */
const op_image *op_renderer_image(const op_renderer *r);

/* The image format path is written in: its extension (".exr", ".png", ".pfm", ".hdr",
 * ".m" (mfilm's text matrix), ".npy" (a NumPy array), case-insensitive), or the film's own for a name without one (/dev/stdout, a FIFO); NULL for
 * another extension. */
const char *op_scene_image_format(const op_scene *scene, const char *path);

/* Writes img to path through op_image_write_*, the format chosen by
 * op_scene_image_format, applying the film's settings: hdrfilm's
 * componentFormat (float16 or float32 EXR) and pixelFormat (rgb, rgba, luminance), ldrfilm's
 * tonemapping (gamma with exposure, or reinhard) and gamma for PNG. */
op_status op_scene_write_image(const op_scene *scene, const op_image *img, const char *path,
                               op_error *err);
/* op_scene_image_format and op_scene_write_image with a description's film (the same result as
 * with the scene built from it): an image assembled elsewhere (--merge-tiles) needs no build. */
const char *op_scene_description_image_format(const op_scene_description *d, const char *path);
op_status op_scene_description_write_image(const op_scene_description *d, const op_image *img,
                                           const char *path, op_error *err);

#ifdef __cplusplus
}
#endif
#endif
