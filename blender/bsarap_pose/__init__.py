"""BS-ARAP Pose: pose a mesh inside Blender with the bsarap solver.

Vertex groups are handle groups (weight > 0.5); *Add controls* makes one Empty per group; moving
or keying the Empties poses the mesh live into the shape key "BS-ARAP pose"; the scene's frame
range bakes to shape keys or a PC2 point cache. Operators: ``bpy.ops.bsarap.*``; panel: 3D
viewport sidebar, tab "BS-ARAP". Modules: handles (vertex groups -> labels), solve (the
per-object solver cache), modifiers (those a posed mesh may keep), handlers (live updates), bake,
props, operators, panel.
"""

from . import handlers, operators, panel, props

_modules = (props, operators, panel, handlers)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
