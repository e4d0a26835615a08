"""Exports an evaluated Blender scene to opaline scene XML.

`export_scene(depsgraph, xml_path)` writes XML_PATH and the meshes into a `meshes/` folder beside
it, and returns an ExportResult (counts and warnings). Problems the user can fix raise
OpalineError with a readable message (no camera, unknown preset, ...).

What is exported: the scene camera; every object instance of the depsgraph that renders (not
hidden for render, not in a collection hidden for render, instancers only when they show
themselves); lights (lights.py); meshes, curves, surfaces, text and metaballs as triangle
meshes with modifiers applied (meshes.py), shared between instances of one data block; each
material slot's BSDF or opaline subsurface (materials.py) with its image textures in a
`textures/` folder (textures.py); the world as a constant or environment-map emitter
(world.py); samples, bounces and the subsurface pre-pass settings from the scene's opaline render
settings (Scene.opaline). Options: selected objects only, collected material files
(MaterialCollector), a frame range (export_frames).
"""

import os

import bpy

from . import camera as camera_mod
from . import lights as lights_mod
from . import materials as materials_mod
from . import meshes as meshes_mod
from . import textures as textures_mod
from . import world as world_mod
from .xml_writer import Element, scene_element, serialize, transform_matrix, write_file
from .. import chooser, compat, presets
from ..errors import OpalineError

GEOMETRY_TYPES = {'MESH', 'CURVE', 'SURFACE', 'FONT', 'META'}
MESH_FOLDER = "meshes"
MATERIAL_FOLDER = "materials"


class ExportResult:
    def __init__(self):
        self.xml_path = None
        self.shapes = 0
        self.lights = 0
        self.meshes_written = 0
        self.meshes_reused = 0
        self.meshes_unchanged = 0   # of the reused: data as at an earlier export, not converted
        self.textures_written = 0
        self.textures_reused = 0
        self.warnings = []
        self.width = 0
        self.height = 0

    def __repr__(self):
        return ("ExportResult(%s: %d shapes, %d lights, meshes written %d reused %d, "
                "%d warnings)" % (self.xml_path, self.shapes, self.lights, self.meshes_written,
                                  self.meshes_reused, len(self.warnings)))


def _rows(m):
    return [[float(m[r][c]) for c in range(4)] for r in range(4)]


def _hidden_collections(scene, view_layer):
    """Names of collections hidden for rendering (hide_render, or excluded in the view layer),
    including everything below them."""
    hidden = set()

    def walk(lc, parent_hidden):
        h = parent_hidden or lc.exclude or lc.collection.hide_render
        if h:
            hidden.add(lc.collection.name)
        for c in lc.children:
            walk(c, h)
    if view_layer is not None:
        walk(view_layer.layer_collection, False)
    return hidden


def _renders(inst, hidden_cols):
    """Whether a depsgraph object instance appears in a render."""
    ob = inst.object
    orig = ob.original
    if inst.is_instance:
        parent = inst.parent.original if inst.parent is not None else None
        return parent is None or not parent.hide_render
    if not getattr(inst, "show_self", True):
        return False
    if orig.hide_render:
        return False
    cols = orig.users_collection
    if cols and all(c.name in hidden_cols for c in cols):
        return False
    return True


def render_samples(scene):
    """(samples, max bounces) from the scene's opaline render settings."""
    o = getattr(scene, "opaline", None)
    if o is not None:
        return max(1, int(o.samples)), int(o.max_bounces)
    return 64, 8


def prepass_settings(scene):
    """(irrSamples, maxPoints; 0: the renderer's default) of the subsurface pre-pass from the
    scene's render settings, or None (the renderer's defaults) when the scene has none."""
    o = getattr(scene, "opaline", None)
    if o is None:
        return None
    return int(o.irr_samples), int(o.max_sss_points)


class MaterialCollector:
    """Copies the material files an export uses into `<xml_dir>/materials/` and names them
    relatively ("materials/NAME.opm"), so the exported folder can be moved. A file already
    there with the same size and modification time is not copied again; two different files
    with one name get distinct names."""

    def __init__(self, xml_dir):
        self.dir = os.path.join(xml_dir, MATERIAL_FOLDER)
        self.names = {}     # absolute source path -> file name in the folder
        self.copied = 0

    def __call__(self, src):
        import shutil
        src = os.path.abspath(src)
        if src not in self.names:
            base, ext = os.path.splitext(os.path.basename(src))
            name, i = base + ext, 1
            while name in self.names.values():
                name, i = "%s_%d%s" % (base, i, ext), i + 1
            os.makedirs(self.dir, exist_ok=True)
            dst = os.path.join(self.dir, name)
            st = os.stat(src)
            try:
                dt = os.stat(dst)
                same = dt.st_size == st.st_size and int(dt.st_mtime) == int(st.st_mtime)
            except OSError:
                same = False
            if not same:
                shutil.copyfile(src, dst)
                shutil.copystat(src, dst)
                self.copied += 1
            self.names[src] = name
        return MATERIAL_FOLDER + "/" + self.names[src]


def frame_path(xml_path, frame):
    """The XML of one frame of a frame-range export: NAME_<frame, 4 digits>.xml beside
    xml_path (batch.py's naming)."""
    stem, ext = os.path.splitext(xml_path)
    return "%s_%04d%s" % (stem, frame, ext or ".xml")


def export_frames(context, xml_path, frames=None, **kw):
    """Exports the current frame to xml_path (frames None) or each frame of the inclusive
    range frames = (first, last) to frame_path(xml_path, f), sharing meshes/ and materials/;
    restores the current frame. kw as for export_scene. Returns the ExportResults."""
    scene = context.scene
    if frames is None:
        return [export_scene(context.evaluated_depsgraph_get(), xml_path, context, **kw)]
    first, last = frames
    cur, sub = scene.frame_current, scene.frame_subframe
    out = []
    try:
        for f in range(first, last + 1):
            scene.frame_set(f)
            out.append(export_scene(context.evaluated_depsgraph_get(), frame_path(xml_path, f),
                                    context, **kw))
    finally:
        scene.frame_set(cur, subframe=sub)
    return out


def _selected(inst):
    """Whether a depsgraph instance belongs to the selection: its object, or for an instance
    its instancer, is selected."""
    ob = inst.parent if (inst.is_instance and inst.parent is not None) else inst.object
    try:
        return ob.original.select_get()
    except RuntimeError:  # not in the view layer
        return False


def mesh_weight(ob):
    """The share of an evaluated geometry object in the mesh export's progress: its face count
    (1 for other geometry)."""
    return max(1, len(ob.data.polygons)) if ob.type == 'MESH' and ob.data is not None else 1


def progress_reporter(progress, interval=0.1):
    """A report(fraction, object_name) that passes progress(fraction, object_name) on at most
    every `interval` seconds, and always at the end (fraction 1); a no-op for progress None."""
    import time
    if progress is None:
        return lambda fraction, name: None
    last = [-interval]

    def report(fraction, name):
        now = time.monotonic()
        if now - last[0] >= interval or fraction >= 1.0:
            last[0] = now
            progress(min(1.0, fraction), name)
    return report


def export_scene(depsgraph, xml_path, context=None, renderer_path=None, samples=None,
                 selected_only=False, collect_materials=False, progress=None):
    """Writes the scene of `depsgraph` to `xml_path`; returns an ExportResult.

    renderer_path: the opaline-render the file is meant for (decides whether presets are
    written by name or by path); samples: overrides the scene's sample count; selected_only:
    only the selected objects (the camera is always written); collect_materials: copy the
    material files into materials/ beside the XML and name them relatively
    (MaterialCollector); progress: progress(fraction, object name) hears how far the mesh
    export got (fraction of the faces, a few times a second at most)."""
    res = ExportResult()
    res.xml_path = os.path.abspath(xml_path)
    warn = res.warnings.append
    scene = depsgraph.scene_eval if hasattr(depsgraph, "scene_eval") else depsgraph.scene
    scene_orig = scene.original if hasattr(scene, "original") else scene
    cam_obj = scene.camera
    if cam_obj is None or cam_obj.type != 'CAMERA':
        raise OpalineError("scene '%s' has no camera: add one and make it the active camera "
                           "(Scene properties > Camera)" % scene_orig.name)
    xml_dir = os.path.dirname(res.xml_path)
    mesh_dir = os.path.join(xml_dir, MESH_FOLDER)

    spp, bounces = render_samples(scene_orig)
    if samples is not None:
        spp = int(samples)
    root = scene_element()
    integ = root.add(Element("integrator", {"type": "path"},
                             comment="max bounces %d" % bounces))
    integ.integer("maxDepth", camera_mod.max_depth_from_bounces(bounces))
    cam_eval = cam_obj.evaluated_get(depsgraph) if hasattr(cam_obj, "evaluated_get") else cam_obj
    root.add(camera_mod.export_camera(scene_orig, cam_eval, _rows(cam_eval.matrix_world), spp,
                                      warn))
    r = scene_orig.render
    res.width, res.height = camera_mod.render_size(r.resolution_x, r.resolution_y,
                                                   r.resolution_percentage)

    textures = textures_mod.TextureWriter(xml_dir)
    world = world_mod.export_world(scene.world, textures, bool(r.film_transparent), warn)
    if world is not None:
        root.add(world)

    # Preset lookups (and whether the renderer finds them by name) are shared by every
    # material of the export.
    pcache = {}
    finds = {}

    def find_preset(name):
        if name not in pcache:
            pcache[name] = chooser.find(name, context)
        return pcache[name]

    def knows(preset):
        if preset.name not in finds:
            finds[preset.name] = presets.renderer_finds(preset, renderer_path, xml_dir)
        return finds[preset.name]

    prepass = prepass_settings(scene_orig)
    collector = MaterialCollector(xml_dir) if collect_materials else None
    uvless = set()      # objects warned for a measured material without UVs
    hidden_cols = _hidden_collections(scene_orig, getattr(depsgraph, "view_layer", None))
    mesh_cache = {}     # key -> {material_index: file name}
    no_uv_keys = set()  # keys of meshes without a UV map
    bsdf_ids = {}       # material name -> id of its shared <bsdf>
    shapes = []
    report = progress_reporter(progress)
    total = max(1, sum(mesh_weight(ob) for ob in depsgraph.objects if ob.type in GEOMETRY_TYPES))
    converted = 0
    for inst in depsgraph.object_instances:
        ob = inst.object
        if ob.type not in GEOMETRY_TYPES and ob.type != 'LIGHT':
            continue
        if not _renders(inst, hidden_cols):
            continue
        if selected_only and not _selected(inst):
            continue
        mw = _rows(inst.matrix_world)
        if ob.type == 'LIGHT':
            el = lights_mod.export_light(ob.data, mw, compat.area_light_divisor(), warn,
                                          bool(getattr(ob, "visible_camera", True)))
            if el is not None:
                root.add(el)
                res.lights += 1
            continue
        orig = ob.original
        has_mods = ob.type != 'MESH' or any(m.show_render for m in orig.modifiers)
        key = ("OB_" + orig.name) if (has_mods and not inst.is_instance) else (
            "ME_" + (orig.data.name if orig.data is not None else orig.name))
        if inst.is_instance and has_mods:
            key = "OB_" + orig.name
        parts = mesh_cache.get(key)
        if parts is None:
            parts = {}
            has_uv = True
            try:
                me = ob.to_mesh()
            except RuntimeError:
                me = None
            if me is not None:
                try:
                    done = meshes_mod.export_mesh(me, mesh_dir, key[3:], lambda f: report(
                        (converted + f * mesh_weight(ob)) / total, orig.name))
                finally:
                    ob.to_mesh_clear()
                parts, has_uv = done.files, done.has_uv
                res.meshes_written += done.written
                res.meshes_reused += done.reused
                res.meshes_unchanged += len(parts) if done.unchanged else 0
            converted += mesh_weight(ob)
            mesh_cache[key] = parts
            if not has_uv:
                no_uv_keys.add(key)
            if not parts:
                warn("object %s has no faces; skipped" % orig.name)
        slots = ob.material_slots
        for mi, fname in sorted(parts.items()):
            mat = None
            if len(slots):
                mat = slots[min(mi, len(slots) - 1)].material
            mat = mat.original if (mat is not None and hasattr(mat, "original")) else mat
            s = Element("shape", {"type": "ply"}, comment="object %s%s" % (
                orig.name, (", slot %d" % mi) if len(parts) > 1 else ""))
            s.string("filename", MESH_FOLDER + "/" + fname)
            s.add(transform_matrix("toWorld", mw))
            sub = materials_mod.subsurface_for(mat, find_preset, knows, xml_dir, warn, prepass,
                                               collector)
            if sub is not None:
                s.add(sub)
                sheen = materials_mod.sheen_for(mat, warn)
                if sheen is not None:
                    s.add(sheen)
                if (key in no_uv_keys and sub.attrs[0][1] != "dipole" and
                        orig.name not in uvless):
                    uvless.add(orig.name)
                    warn("object %s has no UV map: its measured material %s is laid by the "
                         "renderer's box projection at the material's physical size (seams "
                         "where the projection axis changes), not by UVs; unwrap it for "
                         "control (material panel > Unwrap UVs)" % (orig.name, mat.name))
            else:
                mname = mat.name if mat is not None else None
                if mname not in bsdf_ids:
                    bsdf, emitter = materials_mod.bsdf_for(mat, warn, textures)
                    if emitter is not None:
                        bsdf_ids[mname] = (None, bsdf, emitter)
                    else:
                        bid = "bsdf%d" % len(bsdf_ids)
                        bsdf.attrs.append(("id", bid))
                        bsdf.comment = "material %s" % (mname or "(none)")
                        root.add(bsdf)
                        bsdf_ids[mname] = (bid, None, None)
                bid, bsdf, emitter = bsdf_ids[mname]
                if bid is not None:
                    s.add(Element("ref", {"id": bid}))
                else:
                    s.add(bsdf)
                    s.add(emitter)
            shapes.append(s)
    report(1.0, None)
    for s in shapes:
        root.add(s)
    res.shapes = len(shapes)
    res.textures_written, res.textures_reused = textures.written, textures.reused
    if res.shapes == 0 and res.lights == 0 and world is None:
        warn("nothing to render: no visible shapes, lights or world light")
    text = serialize(root, "opaline scene exported from Blender %s, file %s, frame %d" % (
        bpy.app.version_string, os.path.basename(bpy.data.filepath) or "(unsaved)",
        scene_orig.frame_current))
    write_file(res.xml_path, text)
    return res
