"""Headless Cycles CPU bakes of any shader vector into a float image, without leaving a trace.

`bake_vector` routes a vector (built by a callback in a temporary material) into an Emission
shader and bakes EMIT at 1 sample into a 32-bit float image: negative values survive, and the
values are exactly what the shader computed at Blender's bake sample points. Every scene,
object and material setting it changes is put back afterwards, and the temporary material and
image are removed.
"""

import time
from contextlib import contextmanager

import numpy as np

from ..addon.compat import new_material
from ..addon.node_builder import running_line  # noqa: F401 (the line whose bakes we model)
from ..addon.scene_state import SCENE_SETTINGS, restored
from ..addon.bake_target import bake_target_problem, visible_for_bake


def exact_cycles(scene):
    """Cycles on the CPU, one sample, no denoising or adaptivity, a fixed seed: every bake and
    render of the suite is exact and repeatable. Returns scene.cycles."""
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = 1
    cy.use_denoising = False
    cy.use_adaptive_sampling = False
    cy.seed = 0
    return cy


class BakeError(RuntimeError):
    """A bake could not run; the message names the object or setting and the fix."""


@contextmanager
def _selection_kept(context):
    view_layer = context.view_layer
    active = view_layer.objects.active
    selected = [o for o in view_layer.objects if o.select_get()]
    try:
        yield
    finally:
        for o in view_layer.objects:
            o.select_set(o in selected)
        view_layer.objects.active = active


@contextmanager
def _temporary_material(obj, material):
    """Put `material` in every slot of obj (adding one slot if it has none); restore after.
    Assigning through the slot writes where the slot links (object or mesh data)."""
    saved = [slot.material for slot in obj.material_slots]
    added = not saved
    if added:
        obj.data.materials.append(material)
    else:
        for slot in obj.material_slots:
            slot.material = material
    try:
        yield
    finally:
        if added:
            # The mesh had no materials: clear() (unlike pop) also drops the object's slot.
            obj.data.materials.clear()
        else:
            for slot, mat in zip(obj.material_slots, saved):
                slot.material = mat


def bake_vector(obj, build, width, height, uv_map=None, log=None, displacement=None):
    """Bake the vector returned by `build(nodes, links)` (an output socket of a node created in
    the given temporary material's tree) over obj's UV map `uv_map` (default: the active one).

    Returns (pixels (height, width, 3) float32, coverage (height, width) bool, seconds), row 0
    at the bottom. `displacement(nodes, links)`, if given, returns a displacement vector for
    Cycles' true displacement of the surface during the bake. Texels the bake did not write are marked uncovered: the image is cleared to
    alpha 0 and the bake writes alpha 1.
    """
    import bpy

    context = bpy.context
    scene = context.scene
    problem = bake_target_problem(obj, context.view_layer)
    if problem:
        raise BakeError(problem)
    uv_names = [uv.name for uv in obj.data.uv_layers]
    if not uv_names:
        raise BakeError(f"object {obj.name!r} has no UV map; add one (UV > Unwrap) to bake")
    if uv_map is not None and uv_map not in uv_names:
        raise BakeError(f"object {obj.name!r} has no UV map named {uv_map!r}; it has "
                        f"{uv_names}")
    image = bpy.data.images.new("surfgrad_bake", width, height, alpha=True, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    material = new_material("surfgrad_bake")
    try:
        tree = material.node_tree
        nodes, links = tree.nodes, tree.links
        nodes.clear()
        out = nodes.new("ShaderNodeOutputMaterial")
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Strength"].default_value = 1.0
        links.new(build(nodes, links), emit.inputs["Color"])
        links.new(emit.outputs["Emission"], out.inputs["Surface"])
        if displacement is not None:
            # Cycles' true displacement: the vector from `displacement` moves the surface.
            links.new(displacement(nodes, links), out.inputs["Displacement"])
            if hasattr(material, "displacement_method"):
                material.displacement_method = "DISPLACEMENT"
            else:                                           # before 4.x's move
                material.cycles.displacement_method = "DISPLACEMENT"
        target = nodes.new("ShaderNodeTexImage")
        target.image = image
        nodes.active = target
        with restored(scene, SCENE_SETTINGS), _selection_kept(context), \
                visible_for_bake(obj, context.view_layer), _temporary_material(obj, material):
            cy = exact_cycles(scene)
            cy.sample_clamp_direct = 0.0
            cy.sample_clamp_indirect = 0.0
            cy.bake_type = "EMIT"
            bake = scene.render.bake
            bake.margin = 0
            bake.use_clear = True
            bake.target = "IMAGE_TEXTURES"
            bake.use_selected_to_active = False
            for o in context.view_layer.objects:
                o.select_set(False)
            obj.select_set(True)
            context.view_layer.objects.active = obj
            # A cleared float image is (0, 0, 0, 0); baked texels get alpha 1.
            image.pixels.foreach_set(np.zeros(width * height * 4, dtype=np.float32))
            t0 = time.perf_counter()
            kwargs = {"type": "EMIT", "margin": 0, "use_clear": False}
            if uv_map is not None:
                kwargs["uv_layer"] = uv_map
            result = bpy.ops.object.bake(**kwargs)
            seconds = time.perf_counter() - t0
            if result != {"FINISHED"}:
                raise BakeError(f"Cycles bake of {obj.name!r} did not finish ({result})")
        px = np.empty(width * height * 4, dtype=np.float32)
        image.pixels.foreach_get(px)
        px = px.reshape(height, width, 4)
        if log:
            log(f"baked {obj.name} {width}x{height} in {seconds:.2f} s")
        return px[..., :3].copy(), px[..., 3] > 0.5, seconds
    finally:
        bpy.data.materials.remove(material)
        bpy.data.images.remove(image)
