"""What a method adds to the scene for its bake and removes afterwards (the registry's
`adds`): a decal projector, an SG Displace modifier."""

from contextlib import contextmanager

import numpy as np

DISPLACE = {"Amount": 0.1, "Scale": 2.0, "Octaves": 2}
# obj's centre in the decal projector's coordinates: toward -y (the wedge's open end), -z (the
# capsule's and cylinder's ends) and x.
PROJECTOR_OFFSET = (0.25, -0.45, -0.35)


def decal_projector(obj):
    """A temporary empty projecting onto obj: about its size, tilted, its centre off obj's by
    PROJECTOR_OFFSET (in the projector's units), so every shape's boundary and the region
    outside the projector lie on the surface (the round shapes reach well into it: the cone
    is half as wide at its centre). Centred, the wedge's open end (y < -1), the capsule's
    rounded ends and the cylinder's depth fade lay off every object but a cap of the sphere,
    and a group missing them passed compare (tests/test_faults_mutants58b.py)."""
    import bpy
    from mathutils import Euler, Matrix, Vector
    empty = bpy.data.objects.new("SG Decal Projector (temporary)", None)
    bpy.context.scene.collection.objects.link(empty)
    centre = obj.matrix_world @ Vector(np.mean(np.array(obj.bound_box), axis=0))
    size = max(obj.dimensions) * 0.5
    empty.matrix_world = (Matrix.Translation(centre) @ Euler((0.5, 0.3, 0.2)).to_matrix()
                          .to_4x4() @ Matrix.Diagonal((1.1 * size, 0.95 * size, 1.2 * size, 1))
                          @ Matrix.Translation(-Vector(PROJECTOR_OFFSET)))
    bpy.context.view_layer.update()
    return empty


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
