"""Scene export: Blender depsgraph -> opaline scene XML + PLY meshes (see scene.py)."""
