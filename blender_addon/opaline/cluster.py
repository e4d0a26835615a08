"""Render on a SLURM cluster from Blender's render panel (docs/cluster.md).

Shown when the add-on's preferences name the opaline-cluster command: the button exports the
frames (the current one, or the scene's frame range) with the materials collected beside the
XML, so that the cluster's nodes need only the shared folder, and runs
`opaline-cluster submit`, reporting the job id it prints. "Cluster Status" runs
`opaline-cluster status` on the same folder.
"""

import os
import re
import shlex
import subprocess

import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from .errors import OpalineError


def settings(context):
    """(command, partition, extra sbatch arguments) from the preferences; command is '' when no
    cluster is configured."""
    from . import preferences
    p = preferences.get(context)
    if p is None:
        return "", "", ""
    return (bpy.path.abspath(p.cluster_command) if p.cluster_command else "",
            p.cluster_partition.strip(), p.cluster_sbatch_args.strip())


def output_folder(context, folder):
    """The render's folder: `folder` (Blender's // = the .blend's folder) made absolute."""
    return os.path.abspath(bpy.path.abspath(folder or "//opaline_cluster"))


def submit_command(command, xmls, out, partition, sbatch_args, tiles, threads):
    cmd = [command, "submit"] + list(xmls) + ["-o", out, "--tiles", str(tiles),
                                              "--threads", str(threads)]
    if partition:
        cmd += ["--partition", partition]
    if sbatch_args:
        cmd += ["--sbatch-arg=" + sbatch_args]  # one value, which may start with --
    return cmd


class OPALINE_OT_render_cluster(bpy.types.Operator):
    """Export the frames (materials collected beside them) and submit them to the SLURM cluster
    named in the add-on's preferences"""
    bl_idname = "render.opaline_cluster"
    bl_label = "Render on Cluster"

    animation: BoolProperty(name="Animation", default=False,
                            description="Every frame of the scene's frame range (else the "
                                        "current frame)")
    folder: StringProperty(name="Folder", default="//opaline_cluster", subtype='DIR_PATH',
                           description="Where the scenes and images go: a folder every node "
                                       "of the cluster sees (// is the .blend's folder)")
    tiles: IntProperty(name="Tiles", default=1, min=1, max=256,
                       description="Tiles per frame, rendered as separate tasks and merged")
    threads: IntProperty(name="Threads", default=4, min=1, max=1024,
                         description="CPUs per task")

    def execute(self, context):
        from .export import scene as scene_export
        from . import preferences
        command, partition, sbatch_args = settings(context)
        if not command:
            self.report({'ERROR'}, "opaline: no cluster configured (Preferences > Add-ons > "
                        "opaline > opaline-cluster)")
            return {'CANCELLED'}
        if not (os.path.isfile(command) and os.access(command, os.X_OK)):
            self.report({'ERROR'}, "opaline cluster: %s is not an executable program (Preferences "
                        "> Add-ons > opaline > opaline-cluster)" % command)
            return {'CANCELLED'}
        out = output_folder(context, self.folder)
        sc = context.scene
        base = os.path.splitext(os.path.basename(bpy.data.filepath))[0] or "scene"
        xml = os.path.join(out, "scenes", base + ".xml")
        frames = (sc.frame_start, sc.frame_end) if self.animation else (sc.frame_current,) * 2
        try:
            os.makedirs(os.path.dirname(xml), exist_ok=True)
            results = scene_export.export_frames(
                context, xml, frames,
                renderer_path=preferences.find_renderer(context, required=False),
                collect_materials=True)
        except OpalineError as e:
            self.report({'ERROR'}, "opaline cluster: %s" % e)
            return {'CANCELLED'}
        except OSError as e:
            self.report({'ERROR'}, "opaline cluster: cannot export: %s" % e)
            return {'CANCELLED'}
        for res in results:
            for w in res.warnings:
                self.report({'WARNING'}, w)
        cmd = submit_command(command, [r.xml_path for r in results], out, partition,
                             sbatch_args, self.tiles, self.threads)
        print("opaline cluster: %s" % " ".join(shlex.quote(c) for c in cmd))
        try:
            p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               timeout=600)
        except (OSError, subprocess.TimeoutExpired) as e:
            self.report({'ERROR'}, "opaline cluster: cannot run %s: %s" % (command, e))
            return {'CANCELLED'}
        if p.returncode != 0:
            lines = [l for l in p.stderr.splitlines() if l.strip()] or ["exit %d" % p.returncode]
            self.report({'ERROR'}, "opaline cluster: %s" % lines[-1])
            return {'CANCELLED'}
        m = re.search(r"submitted job (\d+)", p.stdout)
        if m:
            context.window_manager["opaline_cluster_job"] = m.group(1)
            self.report({'INFO'}, "opaline: submitted job %s (%d frame%s to %s)" % (
                m.group(1), len(results), "s" if len(results) != 1 else "", out))
        else:
            self.report({'INFO'}, "opaline: %s" % (p.stdout.strip() or "submitted"))
        context.window_manager["opaline_cluster_folder"] = out
        return {'FINISHED'}


class OPALINE_OT_cluster_status(bpy.types.Operator):
    """Show how far the last cluster render is (opaline-cluster status)"""
    bl_idname = "render.opaline_cluster_status"
    bl_label = "Cluster Status"

    def execute(self, context):
        command = settings(context)[0]
        out = context.window_manager.get("opaline_cluster_folder")
        if not command or not out:
            self.report({'ERROR'}, "opaline: nothing submitted to a cluster yet")
            return {'CANCELLED'}
        p = subprocess.run([command, "status", out], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=120)
        for line in p.stdout.splitlines():
            self.report({'INFO'}, line)
        return {'FINISHED'}


class OPALINE_PT_render_cluster(bpy.types.Panel):
    bl_label = "Cluster"
    bl_idname = "RENDER_PT_opaline_cluster"
    bl_parent_id = "RENDER_PT_opaline"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {'OPALINE'}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and bool(settings(context)[0])

    def draw(self, context):
        col = self.layout.column(align=True)
        op = col.operator(OPALINE_OT_render_cluster.bl_idname, text="Render on Cluster",
                          icon='RENDER_STILL')
        op.animation = False
        op = col.operator(OPALINE_OT_render_cluster.bl_idname,
                          text="Render Animation on Cluster", icon='RENDER_ANIMATION')
        op.animation = True
        job = context.window_manager.get("opaline_cluster_job")
        if job:
            col.label(text="Last job: %s" % job)
        col.operator(OPALINE_OT_cluster_status.bl_idname, icon='INFO')


classes = (OPALINE_OT_render_cluster, OPALINE_OT_cluster_status, OPALINE_PT_render_cluster)
