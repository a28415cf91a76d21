"""Gustavson's displacement in Geometry Nodes (his Eq. 3-8): noise along the normal with
analytic normals, and the rest position for bump on top."""

from ..node_vocabulary import Math, VMath
from ...reference import socket_specs as S
from ...reference.group_interfaces import REST_ATTRIBUTE
from ...reference.socket_specs import NOISE_OCTAVES
from .common import FeatureUnavailable, ensure, sub_group, unavailable_reason
from .volume import gradient_noise_group


def displace_group():
    """Gustavson's displacement (Eq. 3-8) in Geometry Nodes: P = P0 + amount h(scale P0) N0,
    and the new normal normalize(N0 - amount (g - (g . N0) N0)) set analytically with Set
    Mesh Normal; h and g are the reference's fractal-sum noise (SG Noise's lattice).
    Raises FeatureUnavailable where Set Mesh Normal does not exist (before 4.5)."""
    reason = unavailable_reason("SG Displace")
    if reason is not None:
        raise FeatureUnavailable(reason)

    def build(b):
        geo, amount = b.input("Geometry"), b.input("Amount")
        scale, octaves, gain = b.input(S.NOISE_SCALE), b.input(S.OCTAVES), b.input(S.GAIN)
        analytic = b.input("Analytic Normals")
        p0 = b.node("GeometryNodeInputPosition").outputs[0]
        n0 = b.normalize(b.node("GeometryNodeInputNormal").outputs[0])
        p = b.scale(p0, scale)
        value, grad = 0.0, (0.0, 0.0, 0.0)
        octave_tree = gradient_noise_group("GeometryNodeTree")
        with b.frame("Fractal sum: sum gain^i noise(2^i scale P0), exact gradient"):
            for i in range(NOISE_OCTAVES):
                freq = 2.0 ** i
                node = sub_group(b, octave_tree, f"octave {i + 1}",
                                 Vector=b.scale(p, freq) if i else p)
                on = b.math(Math.LESS_THAN, float(i), octaves)
                amp = b.math(Math.MULTIPLY, on, b.math(Math.POWER, gain, float(i)))
                value = b.math(Math.ADD, value, b.math(Math.MULTIPLY, amp, node.outputs[0]))
                grad = b.add(grad, b.scale(node.outputs[1], b.math(Math.MULTIPLY, amp, freq)))
            grad = b.scale(grad, scale)
        with b.frame("Eq. 4-8: N = normalize(N0 - amount (g - (g . N0) N0))"):
            g_perp = b.sub(grad, b.scale(n0, b.dot(grad, n0)))
            normal = b.normalize(b.sub(n0, b.scale(g_perp, amount)))
        with b.frame("Keep the rest position (for bump on top) and the new normal"):
            store = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR",
                           domain="POINT")
            b.link(geo, store.inputs["Geometry"])
            store.inputs["Name"].default_value = REST_ATTRIBUTE
            b.link(p0, store.inputs["Value"])
            capture = b.node("GeometryNodeCaptureAttribute", domain="POINT")
            capture.capture_items.new("VECTOR", "Normal")
            b.link(store.outputs["Geometry"], capture.inputs["Geometry"])
            b.link(normal, capture.inputs["Normal"])      # by name: 5.1 added Selection
        with b.frame("Eq. 3: P = P0 + amount h N0, then the analytic normals"):
            setpos = b.node("GeometryNodeSetPosition")
            b.link(capture.outputs["Geometry"], setpos.inputs["Geometry"])
            b.link(b.scale(n0, b.math(Math.MULTIPLY, value, amount)), setpos.inputs["Offset"])
            setn = b.node("GeometryNodeSetMeshNormal", mode="FREE", domain="POINT")
            b.link(setpos.outputs["Geometry"], setn.inputs["Mesh"])
            b.link(capture.outputs["Normal"], setn.inputs["Custom Normal"])
            switch = b.node("GeometryNodeSwitch", input_type="GEOMETRY")
            b.link(analytic, switch.inputs["Switch"])
            b.link(setpos.outputs["Geometry"], switch.inputs["False"])
            b.link(setn.outputs[0], switch.inputs["True"])
        b.output("Geometry", switch.outputs[0])
    return ensure("SG Displace", build, tree_type="GeometryNodeTree")


def rest_position_group():
    def build(b):
        with b.frame(f"Attribute '{REST_ATTRIBUTE}' written by SG Displace"):
            attr = b.node("ShaderNodeAttribute", attribute_type="GEOMETRY",
                          attribute_name=REST_ATTRIBUTE)
        b.output("Rest Position", attr.outputs["Vector"])
    return ensure("SG Rest Position", build)
