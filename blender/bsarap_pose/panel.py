"""The sidebar panel: 3D viewport, N panel, tab "BS-ARAP"."""

from __future__ import annotations

import bpy

from . import claims, solve


class BSARAP_UL_groups(bpy.types.UIList):
    def draw_item(self, context, layout, _data, item, _icon, _active_data, _active_prop, _index=0):
        obj = context.object
        row = layout.row(align=True)
        ok = obj is not None and obj.vertex_groups.get(item.name) is not None
        row.label(text=item.name, icon="GROUP_VERTEX" if ok else "ERROR")
        c = item.control
        # another object's control (this one is a copy of it): the message says which
        own = c is None or obj is None or claims.owner(c) in (None, obj)
        row.label(text=c.name if c else "no control", icon="EMPTY_AXIS" if own else "ERROR")


class BSARAP_PT_pose(bpy.types.Panel):
    bl_label = "BS-ARAP Pose"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "BS-ARAP"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        s = obj.bsarap
        layout.label(text="Handle groups (weight > 0.5):")
        row = layout.row()
        row.template_list("BSARAP_UL_groups", "", s, "groups", s, "active_group", rows=3)
        col = row.column(align=True)
        col.operator("bsarap.add_group", icon="ADD", text="")
        col.operator("bsarap.remove_group", icon="REMOVE", text="")
        if obj.vertex_groups.active is not None:
            layout.label(text=f"Add adds the active vertex group: {obj.vertex_groups.active.name}")
        row = layout.row(align=True)
        row.operator("bsarap.add_controls", icon="EMPTY_AXIS")
        row.operator("bsarap.remove_controls", icon="X", text="")
        layout.prop(s, "live")
        layout.operator("bsarap.pose", icon="FILE_REFRESH")
        if obj.mode == "EDIT":
            layout.label(text="Edit Mode: posing waits until you leave it", icon="INFO")
        warning = solve.scale_warning(obj)
        if warning:
            layout.label(text=warning, icon="ERROR")
        msg = solve.message(obj)
        if msg:
            layout.label(text=msg, icon="INFO")
        status = solve.status(obj)
        if status is not None:
            text, icon = status
            layout.label(text=text, icon=icon)
        st = solve.built(obj)
        if st is not None and st.last_ms is not None:
            layout.label(text=f"Last update: {st.last_ms:.1f} ms")


class BSARAP_PT_settings(bpy.types.Panel):
    bl_label = "Solver"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "BS-ARAP"
    bl_parent_id = "BSARAP_PT_pose"

    def draw(self, context):
        s = context.object.bsarap
        col = self.layout.column()
        col.prop(s, "method")
        col.prop(s, "energy")
        if s.energy == "smooth-rotations":
            col.prop(s, "bending_length")
            # the fraction in the mesh's own units, as the editor shows it
            world = s.bending_length * solve.rest_diagonal(context.object)
            col.label(text=f"Bending length = {world:.4g} units (object space)")
        col.prop(s, "tol")
        col.prop(s, "max_iters")
        col.prop(s, "anderson")
        if s.method == "bsarap-faired":
            col.prop(s, "smoothing")
        if s.method == "bsarap-coarse":
            col.prop(s, "coarse_vertices")
            col.prop(s, "fine_iterations")
            col.prop(s, "settle_iterations")
            col.prop(s, "membrane")
            if s.energy == "smooth-rotations":
                col.prop(s, "coarse_energy")


class BSARAP_PT_bake(bpy.types.Panel):
    bl_label = "Bake"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "BS-ARAP"
    bl_parent_id = "BSARAP_PT_pose"

    def draw(self, context):
        s = context.object.bsarap
        col = self.layout.column()
        col.operator("bsarap.bake_shape_keys", icon="SHAPEKEY_DATA")
        col.prop(s, "pc2_path")
        col.operator("bsarap.bake_point_cache", icon="FILE_CACHE")


classes = (BSARAP_UL_groups, BSARAP_PT_pose, BSARAP_PT_settings, BSARAP_PT_bake)


def register():
    for c in classes:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
