"""Panels of the SSGI node: the compositor sidebar (tab "SSGI") and a child of the SSGI render panel.
They only draw: the node's model, what the prediction image holds, the render buttons and progress."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..ssgi_addon.blender import compiled, node as ssgi_node
from ..ssgi_addon.runtime import jobs, ui_jobs
from . import RenderPropertiesPanel, draw_error, draw_job


def _draw(layout, context):
    scene = context.scene
    tree = scene.compositing_node_group
    nodes = ssgi_node.ssgi_nodes(tree)
    groups = [n.node_tree for n in (tree.nodes if tree is not None else ())
              if n.bl_idname == "CompositorNodeGroup" and n.node_tree is not None and compiled.LAYOUT_PROP in n.node_tree]
    if groups:  # a compiled set-up (docs/compiled.md): Blender's own render shows it, nothing to drive here
        layout.label(text=f"Compiled: {Path(groups[0].get('ssgi_model', '?')).name}", icon="CHECKMARK")
        layout.label(text="F12 and farms render it without the extension")
    if not nodes:
        if not groups:
            layout.label(text="No SSGI node in the compositor", icon="INFO")
        layout.operator("ssgi.setup", icon="NODETREE")
        layout.operator("ssgi.setup", text="Set up SSGI as Nodes", icon="NODE_COMPOSITING").compiled = True
        return
    active = tree.nodes.active if tree is not None else None
    node = active if active is not None and ssgi_node.is_ssgi_node(active) else nodes[0]
    col = layout.column()
    if hasattr(node, "ssgi_model_choice"):
        col.prop(node, "ssgi_model_choice", text="Model")
        if node.ssgi_model_choice == "CUSTOM":
            col.prop(node, "ssgi_model", text="File")
    if hasattr(node, "ssgi_working_res"):
        col.prop(node, "ssgi_working_res", text="Working Res", placeholder="auto")
    if hasattr(node, "ssgi_temporal"):
        col.prop(node, "ssgi_temporal", text="Temporal")
    path = ssgi_node.resolve_model(scene)
    col.label(text=f"Uses: {path.name}" + ("" if path.is_file() else "  (missing!)"),
              icon="CHECKMARK" if path.is_file() else "ERROR")
    st = ssgi_node.image_state(scene)
    if st.get("current"):
        col.label(text=f"Shows frame {st['frame']} (current)", icon="CHECKMARK")
    elif st.get("state") == "prediction":
        col.label(text=f"Stale: holds frame {st['frame']} of {st['scene']!r}", icon="ERROR")
    else:
        col.label(text="Placeholder (magenta): render with SSGI", icon="ERROR")
    layout.operator("ssgi.setup", icon="NODETREE")
    row = layout.row(align=True)
    row.operator("ssgi.render", text="Render SSGI Image", icon="RENDER_STILL").animation = False
    row.operator("ssgi.render", text="Animation", icon="RENDER_ANIMATION").animation = True
    job = jobs.get(ui_jobs.RENDER)
    if draw_job(layout, job) or draw_error(layout, job) or job is None or not job.result:
        return
    r = job.result
    layout.label(text=f"{job.state['status'].capitalize()}: {len(r['frames'])} frame(s) "
                      f"{r['files'][-1] if r['files'] else ''}"[:120])


class SSGI_PT_node(bpy.types.Panel):
    bl_label = "SSGI"
    bl_idname = "SSGI_PT_node"
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "SSGI"

    @classmethod
    def poll(cls, context):
        space = context.space_data
        return space is not None and getattr(space, "tree_type", "") == "CompositorNodeTree"

    def draw(self, context):
        _draw(self.layout, context)


class SSGI_PT_render(RenderPropertiesPanel, bpy.types.Panel):
    bl_label = "SSGI Render"
    bl_idname = "SSGI_PT_render"
    bl_parent_id = "SSGI_PT_main"

    def draw(self, context):
        _draw(self.layout, context)


CLASSES = (SSGI_PT_node, SSGI_PT_render)
