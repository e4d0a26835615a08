/* render_scene.h - the built scene as the renderer's modules see it (the public op_scene is
 * opaque). Built once by scene_build.c, read-only afterwards. */
#ifndef OP_RENDER_SCENE_H
#define OP_RENDER_SCENE_H

#include "geometry/accel.h"
#include "bsdf/bsdf.h"
#include "camera/camera.h"
#include "sss/dipole_profile.h"
#include "light/emitter.h"
#include "medium/medium.h"
#include "camera/film.h"
#include "camera/sampler.h"
#include "opaline_material.h"
#include "opaline_render.h"
#include "geometry/shape.h"

typedef enum op_integrator_type {
    OP_INT_PATH,
    OP_INT_DIRECT,
    OP_INT_NORMALS,
    OP_INT_UV,
    OP_INT_ALBEDO
} op_integrator_type;

typedef struct op_integrator {
    op_integrator_type type;
    int max_depth; /* -1 infinite; 1 = only emitters seen directly; 2 = direct lighting */
    int rr_depth;
    int hide_emitters;
    int emitter_samples; /* direct: samples of every emitter per pixel sample (>= 0) */
    int bsdf_samples;    /* direct: BSDF samples per pixel sample (>= 0) */
    int volumetric;      /* path: 1 for Mitsuba's volpath family, which renders media (the
                            volumetric path tracer; the same as path in a scene without them),
                            0 for path, which ignores media as Mitsuba's path does */
} op_integrator;

/* A measured subsurface material on one shape. */
typedef struct op_sss_desc {
    op_material *material; /* owned by the scene's material list (shared between shapes) */
    double scale;          /* sceneUnitsPerMetre: scene units one metre of material covers
                              (measured materials; a dipole: as its coefficients' unit) */
    int units_given;       /* sceneUnitsPerMetre was given (else a dipole's scale is Mitsuba's) */
    int irr_samples;       /* paths per irradiance point */
    double density;        /* irradiance points per material pixel area */
    int max_points;
    op_v3 albedo_mean;     /* mean albedo, the stand-in reflectance while irradiance is computed */
    int is_dipole;         /* 1: the classical dipole below instead of a material (material NULL) */
    op_sss_dipole dipole;      /* coefficients per scene unit (docs/subsurface-rendering.md) */
    int has_boundary;      /* 1: the shape's <bsdf> gives its surface reflection (below) */
    op_bsdf sheen;         /* that reflection lobe (op_bsdf_boundary) */
    op_bsdf_through through; /* what the boundary lets in and out */
} op_sss_desc;

/* The irradiance points planned for one translucent shape (op_sss_plan, sss/layout.h). */
typedef struct op_sss_plan_entry {
    int points;   /* the irradiance points of its layout */
    int windowed; /* 1: a shape needing more than max_points (a measured material, or the
                     dipole at its profile's spacing): only the points near the view are laid,
                     up to max_points, else the shape is coarsened (sss/layout.c) */
    int finest;   /* the points of its layout's finest level: one per material pixel, or at
                     the profile's spacing (a windowed dipole's levels add up to points) */
    int capped;   /* 1: coarsened to max_points (and warned) */
    int coarse;   /* a measured material needing more than INT32_MAX points: its layout is
                     area-uniform, 4^coarse times fewer points than one per material pixel */
} op_sss_plan_entry;

typedef struct op_shape_rec {
    op_trimesh mesh; /* world space; for an instance a borrowed copy of the scene's prototype in
                        object space (never freed through the shape) */
    int instanced;   /* 1: mesh is a shared prototype placed by place (never an emitter or
                        translucent: those need their world-space triangles) */
    int proto;       /* instanced: the prototype's index in the scene's protos */
    op_placement place;
    int bsdf;      /* index into bsdfs */
    int emitter;   /* index into emitters, or -1 */
    int sss;       /* index into sss, or -1 */
    int interior, exterior; /* indices into media, or -1 (vacuum); both -1: the shape is no
                               medium transition (a path keeps its medium when crossing it) */
    char label[160]; /* "file:line" of the shape, for messages */
} op_shape_rec;

struct op_scene {
    char *path;
    op_scene_description *desc; /* what it was built from (owned; its tree freed once built) */
    op_camera camera;
    op_film film;
    op_sampler sampler;
    op_integrator integrator;
    op_shape_rec *shapes;
    int nshapes;
    op_trimesh *protos; /* object-space meshes shared by instanced shapes */
    int nprotos;
    op_bsdf *bsdfs;
    int nbsdfs;
    int has_passable; /* some shape's bsdf is passable (op_bsdf_passable): shadow rays must
                         look through surfaces */
    op_emitter *emitters;
    int nemitters;
    int env; /* index of the environment emitter, or -1 */
    op_sss_desc *sss;
    op_sss_plan_entry *sss_plan; /* per sss: its planned layout (op_sss_plan) */
    int nsss;
    op_pmedium *media;
    int nmedia;
    int camera_medium; /* index into media of the medium the sensor sits in, or -1 */
    op_material **materials;
    char **material_paths; /* the file each material was opened from */
    int nmaterials;
    unsigned char desc_hash[16]; /* op_sss_desc_hash of the description (translucent scenes) */
    op_tex_cache *textures; /* the images the bsdfs' textures point into */
    op_accel *accel;
    op_v3 bmin, bmax; /* world bounds of the geometry */
    float eps;        /* ray offset scale */
};

#endif
