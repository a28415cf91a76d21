"""What a method adds to the scene for its bake and removes afterwards (the registry's
`adds`): a decal projector, an SG Displace modifier."""

from contextlib import contextmanager

import numpy as np

DISPLACE = {"Amount": 0.1, "Scale": 2.0, "Octaves": 2}
# obj's centre in the decal projector's coordinates: toward -y (the wedge's open end), -z (the
# capsule's and cylinder's ends) and x.
PROJECTOR_OFFSET = (0.25, -0.45, -0.35)


# The projector's tilt, and its half-sizes over the object's reach along its axes.
PROJECTOR_TILT = (0.5, 0.3, 0.2)
PROJECTOR_SIZES = (1.1, 0.95, 1.2)


def decal_projector(obj):
    """A temporary empty projecting onto obj: tilted, each axis about obj's reach along it,
    its centre off obj's by PROJECTOR_OFFSET (in the projector's units), so every shape's
    boundary and the region outside the projector lie on the surface (the round shapes reach
    well into it: the cone is half as wide at its centre). Centred, the wedge's open end
    (y < -1), the capsule's rounded ends and the cylinder's depth fade lay off every object
    but a cap of the sphere, and a group missing them passed compare
    (tests/test_faults_mutants58b.py). Sized by obj's largest dimension on every axis, they
    lay off a long or flat object (a rod 20 x 1 x 1, a disc, a 50 x 0.02 strip): a group
    without the wedge's open end, the depth fade or the capsule's length compared 0.000 deg
    there (tests/test_faults_review59a.py)."""
    import bpy
    from mathutils import Euler, Matrix, Vector
    empty = bpy.data.objects.new("SG Decal Projector (temporary)", None)
    bpy.context.scene.collection.objects.link(empty)
    centre = obj.matrix_world @ Vector(np.mean(np.array(obj.bound_box), axis=0))
    tilt = Euler(PROJECTOR_TILT).to_matrix()
    reach = _reach_along(obj, np.array(centre), np.array(tilt))
    empty.matrix_world = (Matrix.Translation(centre) @ tilt.to_4x4()
                          @ Matrix.Diagonal((*(reach * PROJECTOR_SIZES), 1))
                          @ Matrix.Translation(-Vector(PROJECTOR_OFFSET)))
    bpy.context.view_layer.update()
    return empty


def _reach_along(obj, centre, axes):
    """obj's farthest point from `centre` along each column of `axes` (world metres; its
    evaluated mesh's vertices, as baked: an Array modifier's copies too; or its bounding
    box's corners), none under a thousandth of the largest."""
    import bpy
    data = getattr(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()), "data", None)
    co = np.zeros(len(getattr(data, "vertices", ())) * 3)
    if co.size:
        data.vertices.foreach_get("co", co)
    points = co.reshape(-1, 3) if co.size else np.array(obj.bound_box, dtype=np.float64)
    m = np.array(obj.matrix_world)
    world = points @ m[:3, :3].T + m[:3, 3]
    reach = np.abs((world - centre) @ axes).max(axis=0)
    top = reach.max()
    return np.maximum(reach, 1e-3 * top) if top > 0 else np.full(3, 1.0)


def add_displace_modifier(obj, settings=None):
    """SG Displace as a Geometry Nodes modifier on obj (returns the modifier)."""
    from ..addon import compat
    from ..addon import groups as G
    tree = G.displace_group()
    mod = obj.modifiers.new("SG Displace", "NODES")
    mod.node_group = tree
    for name, value in (settings or DISPLACE).items():
        compat.set_input(mod, name, value)
    obj.data.update()
    return mod


# How each addition is made; it is kept on the inputs attribute of its name.
ADDITIONS = {"projector": decal_projector, "modifier": add_displace_modifier}


@contextmanager
def method_scene(adds, obj, inputs):
    """The scene addition `adds` (None, "projector" or "modifier") for obj, set on inputs
    while the block runs and removed afterwards."""
    import bpy
    if adds is not None:
        setattr(inputs, adds, ADDITIONS[adds](obj))
    try:
        yield inputs
    finally:
        if inputs.projector is not None:
            bpy.data.objects.remove(inputs.projector)
            inputs.projector = None
        if inputs.modifier is not None:
            obj.modifiers.remove(inputs.modifier)
            inputs.modifier = None
