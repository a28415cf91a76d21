"""Meshes a pose or shape keys deform on the frame baked. An object-space bake of a mesh an
Armature modifier deforms while its armature is posed away from its rest pose (a character file
saved on a frame of an animation): Blender bakes the mesh as it renders on the current frame, so
the object-space map holds that pose's normals and reads back right in that pose alone; in the
rest pose (the bind pose an engine skins from) and every other pose it is off by the bones'
turns. Measured (red team 50d, tests/test_faults_assets50d.py): godot-demo-projects'
mannequiny.glb saved on frame 10 of its idle action baked an object-space map 87 degrees (median
texel) from the rest pose's, exit 0 and no word. A tangent-space map follows the deformation and
holds in every pose.
A pose that turns no face of the mesh (bones that only slide, as a door's panels; bones turned
that deform other parts, or control bones) leaves the object-space map the rest pose's: the
bake's check measures the faces' turn on the rendered mesh against the rest pose (red team 53b,
tests/test_faults_assets53b.py: godotengine/tps-demo's door.blend, saved on frame 107 with its
floor panels slid 0.42 m and other bones turned up to 90 degrees, was warned of on every door
part; their maps lay within 0.002 degrees of the rest pose's).
Shape keys mixed into the mesh (shape_key_warning, below) bend an object-space map the same way;
Freeze's tangent map still holds what its stack reads in object space where the deformation put
the surface (frozen_deform_warnings)."""

import numpy as np

# A bone turned less than this from its rest (float noise of an imported rest pose) is at rest.
MAX_TURN_DEG = 0.01


def _turn_deg(posed, rest):
    """Degrees between the rotation parts of two bone matrices (armature space)."""
    a = np.asarray(posed, dtype=np.float64)[:3, :3]
    b = np.asarray(rest, dtype=np.float64)[:3, :3]
    a = a / np.linalg.norm(a, axis=0)
    b = b / np.linalg.norm(b, axis=0)
    c = (np.trace(a.T @ b) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def _moved(posed, rest):
    """The bone's pose moves or scales it (not only turns it) away from its rest."""
    a = np.asarray(posed, dtype=np.float64)[:3, :4]
    b = np.asarray(rest, dtype=np.float64)[:3, :4]
    scale = max(1.0, float(np.abs(b).max()))
    return bool(np.abs(a - b).max() > 1e-5 * scale)


def _posed(obj, depsgraph, normals=False):
    """None, or (armature, modifier, largest bone turn in degrees, largest face turn in degrees
    or None) for the first Armature modifier obj renders with that deforms it by a pose other
    than the rest pose (a root shift too: it moves the positions). With `normals` (an
    object-space bake: only its face normals matter), a pose counts only where it turns a face
    of obj (a shift of the whole rig turns none): bones that slide (a door's panels) or turn
    without deforming it (another part's bones, control bones) leave the rest pose's normals."""
    for md in obj.modifiers:
        arm = getattr(md, "object", None) if md.type == "ARMATURE" else None
        if not md.show_render or arm is None or arm.type != "ARMATURE" \
                or arm.data.pose_position != "POSE" or arm.pose is None:
            continue
        evaluated = arm.evaluated_get(depsgraph)
        bones = evaluated.pose.bones if evaluated.pose else ()
        if _at_rest(bones):
            continue
        if normals:
            # The faces' turn answers what the vertex walk would: no walk (rt54a: 0.9 s of the
            # check's 1.85 s at 500k vertices on 5.2). The message's bone turn: of the bones a
            # vertex group names, read first (the reading re-evaluates the armature, which
            # frees these evaluated bones: read after, 4.2 to 5.0 crashed).
            worst = max((_turn_deg(pb.matrix, pb.bone.matrix_local)
                         for pb in _grouped(obj, md, bones)), default=0.0)
            faces = _face_turn(obj, arm)
            if faces is not None:
                if faces <= MAX_TURN_DEG:
                    continue          # no face of this mesh turned: the rest pose's normals
                return arm, md, worst, faces
            bones = arm.evaluated_get(depsgraph).pose.bones     # (evaluated again)
        bones, whole = _followed(obj, md, bones)   # (the vertex walk only for a posed rig)
        if _at_rest(bones):
            continue
        worst = max(_turn_deg(pb.matrix, pb.bone.matrix_local) for pb in bones)
        if normals and worst <= MAX_TURN_DEG and whole and _one_shift(bones):
            continue                  # the whole mesh moved as one: no normal turns
        # (Without `normals` (Freeze: a stack reading object-space positions), a root shift
        # moves every lookup: a strip shifted 0.3 m froze 29.8 degrees (median) off, unsaid.)
        return arm, md, worst, None
    return None


def _grouped(obj, md, bones):
    """The deforming bones that may move a vertex of obj through md, without reading the
    vertices: every one with envelopes, else those a vertex group of obj names."""
    deform = [pb for pb in bones if pb.bone.use_deform]
    if md.use_bone_envelopes:
        return deform
    names = {g.name for g in obj.vertex_groups} if md.use_vertex_groups else set()
    return [pb for pb in deform if pb.name in names]


def _at_rest(bones):
    return all(_turn_deg(pb.matrix, pb.bone.matrix_local) <= MAX_TURN_DEG and
               not _moved(pb.matrix, pb.bone.matrix_local) for pb in bones)


# Only the bones a vertex follows move the mesh. Measured (rt53a, tests/test_faults_trust53a.py):
# a bone no vertex is weighted to, turned 57.3 degrees, was warned of while every face stayed
# (0.0 degrees); and a root shift with one vertex weighted to no bone (it stays at rest while
# the rest move) turned a face 19.5 degrees with no word, as if the mesh moved as one.

def _followed(obj, md, bones):
    """(the deforming bones some vertex of obj follows through the Armature modifier md,
    whether every vertex follows one: else the ones left at rest break a rigid shift)."""
    deform = [pb for pb in bones if pb.bone.use_deform]
    if md.use_bone_envelopes:          # envelopes reach by distance: every bone may move some
        return deform, False
    if not md.use_vertex_groups:
        return [], False
    # One walk of the vertices' groups, only for a rig posed off its rest (0.55 s at 250k
    # vertices on 5.2).
    names = {pb.name for pb in deform}
    groups = {g.index: g.name for g in obj.vertex_groups if g.name in names}
    weighted, loose = set(), False
    for v in obj.data.vertices:
        here = {groups[g.group] for g in v.groups if g.group in groups and g.weight > 0.0}
        weighted |= here
        loose = loose or not here
    # A vertex group masking the modifier leaves the vertices outside it at rest.
    return [pb for pb in deform if pb.name in weighted], not loose and not md.vertex_group


# The mesh is read as the bake reads it (render mode), not as the viewport shows it. Measured
# (rt54a, tests/test_faults_review54a.py): an Armature modifier shown in renders but not in the
# viewport, or a rig's mesh hidden in viewports (Disable in Viewports), read the viewport's
# undeformed mesh in both poses, 0.0 degrees, so a pose that turned a panel 30 degrees baked
# an object-space map 30 degrees off the rest pose's with no word.

def _surface(obj):
    """obj's rendered mesh now, as the bake evaluates it: float64 vertex positions (V, 3),
    each corner's vertex (L,) and each face's first corner (F,) (Blender stores a face's
    corners in a row)."""
    from .bake_uvs import read_as_baked

    def read(evaluated, _depsgraph):
        mesh = evaluated.to_mesh()
        try:
            co = np.empty(len(mesh.vertices) * 3, np.float32)
            mesh.vertices.foreach_get("co", co)
            corners = np.empty(len(mesh.loops), np.int64)
            mesh.loops.foreach_get("vertex_index", corners)
            starts = np.empty(len(mesh.polygons), np.int64)
            mesh.polygons.foreach_get("loop_start", starts)
        finally:
            evaluated.to_mesh_clear()
        return co.reshape(-1, 3).astype(np.float64), corners, starts
    return read_as_baked(obj, read)


def _face_turn(obj, arm):
    """The largest turn in degrees of obj's faces between this pose and the rest pose (the
    armature's Pose Position switched to Rest Position for the reading and put back), or None
    where it cannot be measured (linked armature data, the topology changes): then the pose is
    taken as turning them. A face whose corners all moved by one shift (within float32 noise)
    kept its normal; the others are measured by Newell's normal in float64."""
    import bpy
    if arm.data.library is not None or getattr(arm.data, "override_library", None):
        return None
    posed, corners, starts = _surface(obj)
    try:
        arm.data.pose_position = "REST"
        bpy.context.view_layer.update()
        rest, corners_rest, starts_rest = _surface(obj)
    finally:
        arm.data.pose_position = "POSE"
        bpy.context.view_layer.update()
    if posed.shape != rest.shape or not np.array_equal(corners, corners_rest) or \
            not np.array_equal(starts, starts_rest):
        return None
    if not len(starts):
        return 0.0
    scale = max(1.0, float(np.abs(rest).max()))
    face = np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(corners))))
    shift = posed - rest
    spread = np.abs(shift[corners] - shift[corners[starts]][face]).max(1)
    bent = np.maximum.reduceat(spread, starts) > 1e-5 * scale
    if not bent.any():
        return 0.0
    nxt = np.arange(len(corners)) + 1
    nxt[np.append(starts[1:], len(corners)) - 1] = starts

    def normals(co):
        n = np.add.reduceat(np.cross(co[corners], co[corners[nxt]]), starts)[bent]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return n / np.where(length > 0, length, 1.0), length[:, 0] > 0

    a, ok_a = normals(posed)
    b, ok_b = normals(rest)
    ok = ok_a & ok_b
    if not ok.any():
        return 0.0
    return float(np.degrees(np.arccos(np.clip((a[ok] * b[ok]).sum(1), -1.0, 1.0))).max())


def _one_shift(bones):
    """Every bone's pose is its rest moved by one and the same translation (a root bone's
    root motion): the skin moves rigidly, and its object-space normals stay the rest pose's."""
    shifts, scale = [], 1.0
    for pb in bones:
        a = np.asarray(pb.matrix, dtype=np.float64)
        b = np.asarray(pb.bone.matrix_local, dtype=np.float64)
        scale = max(scale, float(np.abs(b).max()))
        if np.abs(a[:3, :3] - b[:3, :3]).max() > 1e-5:
            return False              # scaled or sheared
        shifts.append(a[:3, 3] - b[:3, 3])
    shifts = np.array(shifts)
    return bool(len(shifts)) and bool(np.abs(shifts - shifts[0]).max() <= 1e-5 * scale)


def _pose_text(obj, posed):
    import bpy
    arm, md, worst, faces = posed
    turned = f"a bone turned up to {worst:.1f} degrees" if worst > MAX_TURN_DEG else \
        "bones moved from their rest, none turned"
    if faces is not None:
        turned += f", its faces turned up to {faces:.1f} degrees"
    return (f"object {obj.name!r} is deformed by armature {arm.name!r} (modifier {md.name!r}) "
            f"in a pose other than its rest pose on frame {bpy.context.scene.frame_current} "
            f"({turned})")


REST_FIX = ("set the armature's Pose Position to Rest Position (Object Data > Skeleton) before "
            "baking")


def posed_armature_warning(obj, depsgraph):
    """None, or the warning for an object-space bake of obj while an Armature modifier it
    renders with deforms it by a pose other than the rest pose, naming the armature, the
    frame, the largest bone turn and the fixes."""
    posed = _posed(obj, depsgraph, normals=True)
    if posed is None:
        return None
    return (f"{_pose_text(obj, posed)}: the object-space map holds this pose's normals and "
            f"reads back right in this pose alone. For a map that fits the rest pose, "
            f"{REST_FIX}; or bake in tangent space, which holds in every pose")


# Shape keys mixed in turn the faces the same way: the bake holds the mix's normals, while an
# engine's morph targets start from the basis. Measured (rt51a, tests/test_faults_deform51a.py):
# a key folding a quad 60 degrees at value 1 baked that quad 60.0 degrees from the basis map.

def _key_weights(obj, key_block, count, memo=None):
    """Per-vertex weights of the key's vertex group (1 without one; 0 where a vertex is not in
    a named group that exists). memo: {group name: weights} shared by one mix's keys (the
    per-vertex walk costs ~0.7 s a key on a 500k-vertex mesh; L/R groups serve many keys)."""
    if not key_block.vertex_group:
        return np.ones(count)
    group = obj.vertex_groups.get(key_block.vertex_group)
    if group is None:
        return np.ones(count)          # Blender ignores a group name that is not there
    if memo is not None and group.name in memo:
        return memo[group.name]
    weights = np.zeros(count)
    if memo is not None:
        memo[group.name] = weights
    for v in obj.data.vertices:
        for g in v.groups:
            if g.group == group.index:
                weights[v.index] = g.weight
    return weights


def _coordinates(key_block, count):
    co = np.empty(count * 3, dtype=np.float64)
    key_block.data.foreach_get("co", co)
    return co.reshape(count, 3)


def _face_normals(mesh, co):
    """Newell normals (unnormalised) of the mesh's faces at vertex positions co."""
    loops = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loops)
    starts = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_start", starts)
    totals = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", totals)
    face = np.repeat(np.arange(len(starts)), totals)
    nxt = np.arange(len(loops)) + 1
    ends = starts + totals
    nxt[ends - 1] = starts                              # each face's last corner wraps around
    a, b = co[loops], co[loops[nxt]]
    cross = np.cross(a, b)
    out = np.zeros((len(starts), 3))
    np.add.at(out, face, cross)
    return out


def mixed_shape_keys(obj):
    """[(key name, value)] of the relative shape keys the render mixes into obj's mesh: the
    pinned one (Shape Key Lock) at 1, else the unmuted ones whose value is not 0."""
    key = getattr(obj.data, "shape_keys", None)
    if key is None or not key.use_relative or len(key.key_blocks) < 2:
        return []
    if obj.show_only_shape_key:
        block = _pinned_key(obj, key)
        return [(block, 1.0)] if block is not None else []
    return [(k, k.value) for k in key.key_blocks
            if k != key.reference_key and not k.mute and k.value != 0.0]


# Absolute keys (Relative unticked): the mesh is the keys interpolated at the Evaluation Time
# along their frames, not a mix of values. Measured (rt53a, tests/test_faults_trust53a.py): a key
# folding a quad 60 degrees, Evaluation Time on its frame, baked that quad 60.0 degrees from the
# basis map, exit 0 and no word (mixed_shape_keys saw no relative keys).

def _curve_weights(t, kind):
    """The weights Blender's absolute keys give the keys around t (0..1 between the middle two):
    linear, cardinal (tension 0.71), Catmull-Rom (0.5) or uniform B-spline."""
    if kind == "KEY_LINEAR":
        return np.array([0.0, 1.0 - t, t, 0.0])
    if kind == "KEY_BSPLINE":
        return np.array([(1 - t) ** 3, 3 * t ** 3 - 6 * t ** 2 + 4, -3 * t ** 3 + 3 * t ** 2 +
                         3 * t + 1, t ** 3]) / 6.0
    c = 0.71 if kind == "KEY_CARDINAL" else 0.5          # KEY_CATMULL_ROM
    return np.array([-c * t ** 3 + 2 * c * t ** 2 - c * t,
                     (2 - c) * t ** 3 + (c - 3) * t ** 2 + 1,
                     (c - 2) * t ** 3 + (3 - 2 * c) * t ** 2 + c * t,
                     c * t ** 3 - c * t ** 2])


def _absolute_blocks(key):
    """[(key block, weight)] Blender's absolute keys take at the key's Evaluation Time."""
    blocks = list(key.key_blocks)
    frames = [b.frame for b in blocks]
    t = min(max(key.eval_time, frames[0]), frames[-1])
    i = next((j for j in range(len(blocks) - 1) if frames[j + 1] >= t), len(blocks) - 2)
    around = [blocks[max(i - 1, 0)], blocks[i], blocks[i + 1], blocks[min(i + 2, len(blocks) - 1)]]
    spline = "KEY_BSPLINE" in (around[1].interpolation, around[2].interpolation)
    span = frames[i + 1] - frames[i]
    if not spline and (t <= frames[i] or t >= frames[i + 1] or span == 0.0):
        return [(around[1] if t <= frames[i] else around[2], 1.0)]
    d = (t - frames[i]) / span if span else 0.0
    w = _curve_weights(d, around[1].interpolation)
    if around[2].interpolation != around[1].interpolation:
        w = w + d * (_curve_weights(d, around[2].interpolation) - w)
    taken = {}
    for b, x in zip(around, w):              # the ends repeat the first or last key
        taken[b.name] = (b, taken.get(b.name, (b, 0.0))[1] + float(x))
    return [(b, x) for b, x in taken.values() if x != 0.0]


def _pinned_key(obj, key):
    """The key block Shape Key Lock shows (None: the basis, also for a muted pin)."""
    index = obj.active_shape_key_index
    block = key.key_blocks[index] if 0 < index < len(key.key_blocks) else None
    # Blender shows the basis for a pinned key that is muted.
    return block if block is not None and block != key.reference_key and not block.mute \
        else None


def _absolute_shape(obj):
    """None, or ([(key, weight)], vertex positions) of the absolute keys at the Evaluation
    Time where they move the mesh off the basis."""
    key = obj.data.shape_keys
    count = len(obj.data.vertices)
    taken = _absolute_blocks(key)
    if taken == [(key.reference_key, 1.0)]:
        return None
    co = sum(w * _coordinates(b, count) for b, w in taken)
    return taken, co


def _shape_turn(obj):
    """None, or ([(key, value)] mixed in, the largest face turn in degrees from the basis,
    the key's Evaluation Time where its keys are absolute, else None)."""
    if obj.type != "MESH":
        return None
    key = getattr(obj.data, "shape_keys", None)
    absolute = key is not None and not key.use_relative and len(key.key_blocks) >= 2
    mesh = obj.data
    count = len(mesh.vertices)
    if absolute:
        if obj.show_only_shape_key:                # the pin shows its key as stored
            block = _pinned_key(obj, key)
            if block is None:
                return None
            mixed, co = [(block, 1.0)], _coordinates(block, count)
        else:
            found = _absolute_shape(obj)
            if found is None:
                return None
            mixed, co = found
        basis = _coordinates(key.reference_key, count)
    else:
        mixed = mixed_shape_keys(obj)
        if not mixed:
            return None
        basis = _coordinates(mesh.shape_keys.reference_key, count)
        co = basis.copy()
        memo = {}
        for block, value in mixed:
            # A pinned key is shown as it is stored (its own Relative To is not used).
            relative = block.relative_key if block.relative_key is not None and \
                not obj.show_only_shape_key else mesh.shape_keys.reference_key
            delta = _coordinates(block, count) - _coordinates(relative, count)
            co += value * _key_weights(obj, block, count, memo)[:, None] * delta
    a, b = _face_normals(mesh, basis), _face_normals(mesh, co)
    la, lb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    ok = (la > 0) & (lb > 0)
    if not ok.any():
        return None
    c = (a[ok] * b[ok]).sum(1) / (la[ok] * lb[ok])
    worst = float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))).max())
    eval_time = key.eval_time if absolute and not obj.show_only_shape_key else None
    return None if worst <= MAX_TURN_DEG else (mixed, worst, eval_time)


def _keys_text(obj, turned):
    mixed, worst, eval_time = turned
    names = ", ".join(f"{block.name!r} at {value:g}" for block, value in mixed[:4]) + \
        (f" and {len(mixed) - 4} more" if len(mixed) > 4 else "")
    pinned = " (pinned: Shape Key Lock)" if obj.show_only_shape_key else ""
    absolute = "" if eval_time is None else \
        f" (absolute keys, Relative unticked: Evaluation Time {eval_time:g})"
    return (f"object {obj.name!r} has shape keys mixed in{pinned}{absolute} ({names}) that "
            f"turn its faces up to {worst:.1f} degrees from the basis")


def _keys_fix(obj, turned):
    if obj.show_only_shape_key:
        return "untick Shape Key Lock (Object Data > Shape Keys)"
    if turned[2] is not None:
        keys = obj.data.shape_keys
        basis = keys.reference_key
        # A B-spline key blends its neighbours even on its own frame.
        spline = [b.name for b in keys.key_blocks if b.interpolation == "KEY_BSPLINE"]
        linear = f" and {', '.join(map(repr, spline[:4]))}'s Interpolation to Linear" \
            if spline else ""
        return (f"set Evaluation Time to {basis.name!r}'s frame ({basis.frame:g}){linear} "
                f"(Object Data > Shape Keys)")
    return "set those keys' values to 0 (Object Data > Shape Keys)"


def shape_key_warning(obj):
    """None, or the warning for an object-space bake of obj while shape keys are mixed into its
    mesh and turn its faces from the basis, naming the keys, the largest turn and the fixes."""
    turned = _shape_turn(obj)
    if turned is None:
        return None
    return (f"{_keys_text(obj, turned)}: the object-space map holds the mixed shape's normals "
            f"and reads back right with this mix alone. For a map that fits the basis, "
            f"{_keys_fix(obj, turned)} before baking; or bake in tangent space, which holds "
            f"in every mix")


def frozen_deform_warnings(obj, depsgraph, readers):
    """Freeze bakes in tangent space, which follows the deformation; but a stack that reads
    positions or normals in object space (`readers`: those nodes, named) looks them up where
    the pose or shape-key mix puts the surface, so the frozen map holds this pose's lookup and
    fits no other pose (the rest pose included): the warnings, each naming the fix."""
    if not readers:
        return []
    names = ", ".join(readers[:4]) + \
        (f" and {len(readers) - 4} more" if len(readers) > 4 else "")
    what = (f": the stack reads object-space positions or normals ({names}) where this "
            f"{{}} puts the surface, so the frozen map holds this {{}}'s look and fits no other "
            f"(the {{}} included). To freeze the {{}}'s look, {{}} before freezing")
    out = []
    posed = _posed(obj, depsgraph)
    if posed is not None:
        out.append(_pose_text(obj, posed) + what.format(
            "pose", "pose", "rest pose", "rest pose",
            REST_FIX.replace(" before baking", "")))
    turned = _shape_turn(obj)
    if turned is not None:
        out.append(_keys_text(obj, turned) + what.format(
            "mix", "mix", "basis", "basis", _keys_fix(obj, turned)))
    return out
