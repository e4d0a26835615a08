"""Render on a SLURM cluster from Blender's render panel (docs/cluster.md).

The buttons export the frames (the current one, or the scene's frame range) with the materials
collected beside the XML, so that the cluster's nodes need only the shared folder, and run
`opaline-cluster submit`: on SLURM when the add-on's preferences name the opaline-cluster
command (reporting the job id it prints), or on this machine without SLURM (`--local`, in the
background, with the opaline-cluster beside the renderer when none is named). "Cluster Status"
runs `opaline-cluster status` on the same folder.
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


def local_program(context):
    """The opaline-cluster that renders on this machine: the preferences' one, else the one
    installed beside the renderer; '' when there is none."""
    from . import preferences
    command = settings(context)[0]
    if command:
        return command
    renderer = preferences.find_renderer(context, required=False)
    if renderer:
        beside = os.path.join(os.path.dirname(renderer), "opaline-cluster")
        if os.path.isfile(beside) and os.access(beside, os.X_OK):
            return beside
    return ""


def output_folder(context, folder):
    """The render's folder: `folder` (Blender's // = the .blend's folder) made absolute."""
    return os.path.abspath(bpy.path.abspath(folder or "//opaline_cluster"))


def submit_command(command, xmls, out, partition, sbatch_args, tiles, threads, local=False):
    cmd = [command, "submit"] + list(xmls) + ["-o", out, "--tiles", str(tiles),
                                              "--threads", str(threads)]
    if local:
        return cmd + ["--local"]
    if partition:
        cmd += ["--partition", partition]
    if sbatch_args:
        cmd += ["--sbatch-arg=" + sbatch_args]  # one value, which may start with --
    return cmd


class OPALINE_OT_render_cluster(bpy.types.Operator):
    """Export the frames (materials collected beside them) and submit them to the SLURM cluster
    named in the add-on's preferences, or render them on this machine in the background"""
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
    local: BoolProperty(name="On This Machine", default=False,
                        description="Run the tasks here, one after another, in the background "
                                    "(no SLURM); Cluster Status shows how far they are")

    def execute(self, context):
        from .export import scene as scene_export
        from . import preferences
        command, partition, sbatch_args = settings(context)
        where = "Preferences > Add-ons > opaline > opaline-cluster"
        if self.local:
            command = local_program(context)
            where += ", or install opaline-cluster beside opaline-render"
        if not command:
            self.report({'ERROR'}, "opaline: no %s (%s)" % (
                "opaline-cluster found" if self.local else "cluster configured", where))
            return {'CANCELLED'}
        if not (os.path.isfile(command) and os.access(command, os.X_OK)):
            self.report({'ERROR'}, "opaline cluster: %s is not an executable program (%s)"
                        % (command, where))
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
                             sbatch_args, self.tiles, self.threads, local=self.local)
        print("opaline cluster: %s" % " ".join(shlex.quote(c) for c in cmd))
        context.window_manager["opaline_cluster_folder"] = out
        context.window_manager["opaline_cluster_program"] = command
        if self.local:
            return self._start_local(cmd, out, len(results))
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
        return {'FINISHED'}

    def _start_local(self, cmd, out, frames):
        """Starts cmd (submit --local) in a session of its own, so that it outlives neither
        Blender's UI nor a closed window's input, its output in OUT/opaline-cluster-local.log."""
        log = os.path.join(out, "opaline-cluster-local.log")
        try:
            with open(log, "w") as f:
                subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=f, stderr=subprocess.STDOUT,
                                 start_new_session=True)
        except OSError as e:
            self.report({'ERROR'}, "opaline cluster: cannot run %s: %s" % (cmd[0], e))
            return {'CANCELLED'}
        self.report({'INFO'}, "opaline: rendering %d frame%s here in the background into %s "
                    "(Cluster Status shows how far; log: %s)"
                    % (frames, "s" if frames != 1 else "", out, log))
        return {'FINISHED'}


class OPALINE_OT_cluster_status(bpy.types.Operator):
    """Show how far the last cluster render is (opaline-cluster status)"""
    bl_idname = "render.opaline_cluster_status"
    bl_label = "Cluster Status"

    def execute(self, context):
        command = context.window_manager.get("opaline_cluster_program") or settings(context)[0]
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
        return context.engine in cls.COMPAT_ENGINES and bool(local_program(context))

    def draw(self, context):
        col = self.layout.column(align=True)
        if settings(context)[0]:
            op = col.operator(OPALINE_OT_render_cluster.bl_idname, text="Render on Cluster",
                              icon='RENDER_STILL')
            op.animation, op.local = False, False
            op = col.operator(OPALINE_OT_render_cluster.bl_idname,
                              text="Render Animation on Cluster", icon='RENDER_ANIMATION')
            op.animation, op.local = True, False
            job = context.window_manager.get("opaline_cluster_job")
            if job:
                col.label(text="Last job: %s" % job)
        else:
            col.label(text="No SLURM cluster set (Preferences > Add-ons > opaline)")
        col.separator()
        op = col.operator(OPALINE_OT_render_cluster.bl_idname, text="Render Here in Background",
                          icon='RENDER_STILL')
        op.animation, op.local = False, True
        op = col.operator(OPALINE_OT_render_cluster.bl_idname,
                          text="Render Animation Here in Background", icon='RENDER_ANIMATION')
        op.animation, op.local = True, True
        col.operator(OPALINE_OT_cluster_status.bl_idname, icon='INFO')


classes = (OPALINE_OT_render_cluster, OPALINE_OT_cluster_status, OPALINE_PT_render_cluster)
