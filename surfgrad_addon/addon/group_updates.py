"""A file's stale surface-gradient groups and their update in place. A group built by an older
surfgrad, or on another Blender line, renders as that one built it until something rebuilds
it; some are wrong here (a group built on 5.0+ chooses with a Menu Switch, which 4.5 drops: the
group outputs zero). Nothing is rebuilt when a file opens: the sidebar says so, and Update
surfgrad Groups rebuilds them (node_builder.ensure_group keeps their nodes' values and links).
"""

import re
import textwrap

import bpy

from . import groups as G
from .group_names import (INSIDE_KEY, LINE_KEY, VERSION_KEY, fitting_name,
                          is_copy_name)
from .all_or_nothing import all_or_nothing
from .node_builder import checked_first, edited_inside, running_line, take_notes

_COPY = re.compile(r"\.\d+$")        # Blender's ".001" of an appended copy


def report_notes(op):
    """Warn of what the groups' rebuilds in an operator could not carry over (a choice this
    Blender cannot read, a link it cannot keep), naming each node: where the artist looks."""
    for text in take_notes():
        op.report({'WARNING'}, text)


def stale_groups():
    """Our groups in this file (local, editable) built by an older surfgrad or for another
    Blender line, or named by an older one (a per-image group); a newer surfgrad's are left
    alone (node_builder refuses them)."""
    line = running_line().line
    return [g for g in bpy.data.node_groups
            if g.library is None and g.override_library is None and g.is_editable
            and isinstance(g.get(VERSION_KEY), int)
            and (g[VERSION_KEY] < G.VERSION or g[VERSION_KEY] == G.VERSION
                 and (g.get(LINE_KEY) != line
                      or not _COPY.search(g.name) and renamed_target(g) is not None))]


def renamed_away(tree):
    """True when group `tree`'s name (less Blender's ".001") is none that surfgrad gives: the
    artist renamed it, and which group it is (so its rebuild) cannot be told from it."""
    name = _COPY.sub("", tree.name)
    if name in G.BY_NAME or name in _HELPERS:
        return False
    given = _given_name(tree, name)
    return given is None or (given != name and not _cut_for_copy(name, given))


def _cut_for_copy(name, given):
    """Whether `name` (less its ".NNN") is Blender's name for a copy of the group named `given`
    that had no room for ".001" (group_names.is_copy_name). Taken as renamed since rt57a,
    Update left it with "rename it back", to a name the original holds (rt58a)."""
    return is_copy_name(name, given)


# Groups named after the UV map their own node holds ("SG Normal Map [UVMap]"): a name that
# only starts so ("SG Normal Map [UVMap] mine", the artist's rename) is not the one surfgrad
# gives, and its rebuild (the group of the UV map's name) cannot reach it (rt57a).
_UV_NAMED = {"SG Normal Map": "ShaderNodeNormalMap", "SG Procedural Basis": "ShaderNodeUVMap",
             ".SG MikkTSpace Frame": "ShaderNodeNormalMap"}
_FILTERED = "SG Height Map Forward"


def _given_name(tree, name):
    """The name surfgrad gives the group `tree` whose (copy-less) name is `name`, as its
    interior says it (the UV map, the filter width), or None where its name has none of
    surfgrad's beginnings. A per-image group's name is taken as given (renamed_target moves
    one named after an older image name)."""
    for base, node in _UV_NAMED.items():
        if name == base:
            return name                 # (as before: a name surfgrad gives, whatever inside)
        if name.startswith(base + " ["):
            uv = _interior(tree, node, "uv_map")
            return fitting_name(base + (f" [{uv}]" if uv else ""))
    if name.startswith(_FILTERED + " (filter "):
        try:
            width = float(name[len(_FILTERED + " (filter "):].split(")")[0])
        except ValueError:
            return None
        return fitting_name(f"{_FILTERED} (filter {width:g})")
    return name if any(name.startswith(prefix) for prefix in _BY_PREFIX) else None


# A renamed group may be the artist's own version (surfgrad's advice for an edited group is
# to rename it): left as it is unless renamed back.
RENAMED_FIX = ("to have it updated, rename it back to its name in the Add menu (Surface "
               "Gradient; an edit inside it is then replaced), then update again")


def stale_text(stale):
    """What the sidebar says of `stale` groups (a list; empty: None). Those the artist renamed
    are named apart: Update cannot rebuild them (it said so and left them, while the sidebar
    kept saying it rebuilds them)."""
    if not stale:
        return None
    here = running_line().line
    lines = sorted({g.get(LINE_KEY) for g in stale} - {None, here})
    where = f" or for Blender {', '.join(lines)}" if lines else ""
    renamed = sorted(g.name for g in stale if renamed_away(g))
    texts = []
    if len(renamed) < len(stale):
        texts.append(f"{len(stale) - len(renamed)} surface-gradient group(s) were built by an "
                     f"older surfgrad{where}, and may render differently here: Update "
                     f"surfgrad Groups rebuilds them for Blender {here}")
    if renamed:
        names = ", ".join(repr(n) for n in renamed[:3]) + (", ..." if len(renamed) > 3 else "")
        texts.append(f"{len(renamed)} older surface-gradient group(s) were renamed ({names}), "
                     f"and may render differently here; surfgrad leaves them as they are (yours "
                     f"now): {RENAMED_FIX.replace('have it', 'have one')}")
    return ". ".join(texts)


def _library(group):
    """The library `group` comes from: its own, or (a library override, whose rebuild the file
    would not save) its reference's; None for a local group."""
    if group.library is not None:
        return group.library
    override = getattr(group, "override_library", None)
    reference = override.reference if override is not None else None
    return getattr(reference, "library", None)


def linked_stale_text():
    """What the sidebar says of our groups linked from a library (a linked material's, or a
    library override of one) that an older surfgrad or another Blender line built: they render
    as built (some wrong: 4.5 drops a 5.x group's Menu Switch), and Update cannot reach them;
    None when there are none."""
    line = running_line().line
    stale = [g for g in bpy.data.node_groups
             if _library(g) is not None and isinstance(g.get(VERSION_KEY), int)
             and (g[VERSION_KEY] < G.VERSION or g.get(LINE_KEY) != line)]
    if not stale:
        return None
    libraries = ", ".join(sorted({repr(_library(g).filepath) for g in stale}))
    lines = sorted({g.get(LINE_KEY) for g in stale} - {None, line})
    where = f" or for Blender {', '.join(lines)}" if lines else ""
    return (f"{len(stale)} surface-gradient group(s) linked from {libraries} were built by an "
            f"older surfgrad{where}, and may render differently here; this file cannot "
            f"change them: update them in that file with Blender {line} (Update surfgrad "
            f"Groups there, then save it), or link from a file made for Blender {line}")


# The sidebar's edited-inside check digests every node of every group (about 24 us a node:
# 386 ms a redraw with 107 groups, 18,689 nodes). Each redraw digests only what may have
# changed: a group shown in the editor (where an artist edits inside), a new one, one whose
# name or stamp changed; then the others, least recently checked first, until
# EDITED_NODE_BUDGET nodes are digested (an edit elsewhere, e.g. by a script, shows within a
# few redraws; an Add or Update refuses an edited group whatever the sidebar shows).
EDITED_NODE_BUDGET = 200
_EDITED = {}            # session_uid -> [fingerprint, edited, redraw last digested]
_REDRAWS = [0]


def _fingerprint(group):
    return group.name, group.get(INSIDE_KEY)      # (len() of a node collection counts them)


def edited_groups(shown=()):
    """This file's current groups the artist edited inside (see EDITED_NODE_BUDGET); `shown`:
    the node trees the editor shows, always digested."""
    line = running_line().line
    # (Not one renamed away from surfgrad's names: the artist's own version, as the message
    # asks; it nagged on, though every Add made surfgrad's own beside it.)
    current = [g for g in bpy.data.node_groups
               if g.library is None and g.get(VERSION_KEY) == G.VERSION
               and g.get(LINE_KEY) == line and not renamed_away(g)]
    _REDRAWS[0] += 1
    uids = {g.session_uid for g in current}
    for uid in set(_EDITED) - uids:
        del _EDITED[uid]
    shown = {t.session_uid for t in shown if t is not None}
    due, rest = [], []
    for g in current:
        seen = _EDITED.get(g.session_uid)
        fresh = g.session_uid in shown or seen is None or seen[0] != _fingerprint(g)
        (due if fresh else rest).append(g)
    rest.sort(key=lambda g: _EDITED[g.session_uid][2])
    budget = EDITED_NODE_BUDGET
    for i, g in enumerate(due + rest):
        if i >= len(due) and budget <= 0:
            break
        _EDITED[g.session_uid] = [_fingerprint(g), edited_inside(g), _REDRAWS[0]]
        budget -= len(g.nodes)
    return [g for g in current if _EDITED[g.session_uid][1]]


def edited_text(shown=()):
    """What the sidebar says of this file's current groups the artist edited inside (a node
    muted, added or set otherwise): every request for one is refused (node_builder), so the
    artist hears of it before an Add fails; None when there are none."""
    edited = sorted(g.name for g in edited_groups(shown))
    if not edited:
        return None
    names = ", ".join(repr(n) for n in edited[:3]) + (", ..." if len(edited) > 3 else "")
    return (f"{len(edited)} surface-gradient group(s) were edited inside after surfgrad made "
            f"them ({names}): surfgrad will not add or use them as its own; rename each to "
            f"keep your version, so surfgrad can add its own")


def _interior(tree, bl_idname, prop):
    """`prop` of the first node of type `bl_idname` in `tree` (None if there is none)."""
    node = next((n for n in tree.nodes if n.bl_idname == bl_idname), None)
    return None if node is None else getattr(node, prop)


# Per-image group key -> its builder and the options its key stands for.
_PER_IMAGE = {"SG Height Map HQ": (G.height_map_group, {"variant": "hq"}),
              "SG Height Map One-Texel": (G.height_map_group, {"variant": "one-texel"}),
              "SG Triplanar Height": (G.triplanar_height_group, {}),
              "SG Parallax": (G.parallax_group, {})}


def _per_image_request(tree):
    """(key, images, extension) that per-image group `tree` was built for, as its Image
    Texture nodes hold them (one image per plane for triplanar), or None where they cannot
    be told (not a per-image group, an image removed)."""
    name = _COPY.sub("", tree.name)
    key = next((k for k in _PER_IMAGE if name.startswith(k + " [")), None)
    if key is None:
        return None
    planes = 3 if key == "SG Triplanar Height" else 1
    taps = _plane_taps(tree, planes)
    if taps is None:
        return None
    images = [t.image for t in taps]
    return None if None in images else (key, images, taps[0].extension)


# The sidebar asks every redraw which per-image groups an older surfgrad named: walking their
# nodes for the Image Texture ones cost 20 ms a redraw with 80 of them. The names of each
# plane's first one are kept (the images are read anew each time: an image renamed renames the
# group; one removed leaves every node of it empty).
_TAPS = {}              # session_uid -> (group name, first Image Texture node name per plane)


def _plane_taps(tree, planes):
    """The first Image Texture node of each of group `tree`'s planes, or None where its nodes
    cannot hold that many planes (as groups.common.held_images)."""
    known = _TAPS.get(tree.session_uid)
    if known is not None and known[0] == tree.name:
        taps = [tree.nodes.get(name) for name in known[1]]
        if all(t is not None and t.bl_idname == "ShaderNodeTexImage" for t in taps):
            return taps
    taps = [nd for nd in tree.nodes if nd.bl_idname == "ShaderNodeTexImage"]
    if not taps or len(taps) % planes or None in [t.image for t in taps]:
        _TAPS.pop(tree.session_uid, None)
        return None
    taps = taps[::len(taps) // planes]
    _TAPS[tree.session_uid] = (tree.name, [t.name for t in taps])
    return taps


def _unread_image(tree):
    """Why per-image height group `tree` cannot be rebuilt now (one update refused for it
    alone): an image it steps by whose pixels Blender does not hold (a missing or unreadable
    file); else None."""
    request = _per_image_request(tree)
    if request is None or request[0] == "SG Parallax":        # (parallax takes no texel step)
        return None
    unread = next((im for im in request[1] if not (im.size[0] and im.size[1])), None)
    return unread and (f"its image {unread.name!r} has no pixels here (its file "
                       f"{unread.filepath!r} is missing or unreadable): fix it, then update "
                       f"again")


def _per_image(tree):
    """A builder call for per-image group `tree`: its images and extension as its nodes hold
    them now (read now: the call runs more than once, node_builder.checked_first, and the
    first run rebuilds the tree, which frees its nodes)."""
    request = _per_image_request(tree)
    if request is None:
        return None
    key, images, extension = request
    build, options = _PER_IMAGE[key]
    if key == "SG Triplanar Height":
        return lambda: build(images=images, extension=extension)
    return lambda: build(image=images[0], extension=extension, **options)


def _older_names(key, images, extension):
    """The names older surfgrads gave the per-image group `key` built for `images` and
    `extension`: up to version 22 the images' names (a library's image without its library)
    and no extension; version 23 did not escape " | " in a triplanar plane's image name."""
    names = [im.name for im in images]
    label = names[0] if len(set(names)) == 1 else " | ".join(names)
    full = [im.name_full for im in images]
    label23 = full[0] if len(set(full)) == 1 else " | ".join(full)
    return {fitting_name(f"{key} [{label}]"),
            fitting_name(f"{key} [{label23}]" + ("" if extension == "REPEAT"
                                                 else f" ({extension})"))}


def renamed_target(tree, any_name=False):
    """The name per-image group `tree` gets now, where an older surfgrad named it otherwise
    (its name, or its ".001" copy's, is what that version called it), or with `any_name`
    where its name is any other (an image of another name: renamed, or appended beside one
    of its name); else None."""
    request = _per_image_request(tree)
    if request is None:
        return None
    target = fitting_name(G.image_group_name(*request))
    name = _COPY.sub("", tree.name)
    return target if tree.name != target and (
        any_name or name in _older_names(*request) | {target}) else None


# Name (before " [" or " (filter") -> how to make its builder call from the tree.
_BY_PREFIX = {
    "SG Normal Map [": lambda t: (lambda uv=_interior(t, "ShaderNodeNormalMap", "uv_map"):
                                  lambda: G.normal_map_group(uv))(),
    "SG Procedural Basis [": lambda t: (lambda uv=_interior(t, "ShaderNodeUVMap", "uv_map"):
                                        lambda: G.procedural_basis_group(uv))(),
    ".SG MikkTSpace Frame": lambda t: (lambda uv=_interior(t, "ShaderNodeNormalMap", "uv_map"):
                                       lambda: G.mikktspace_frame_group(uv))(),
    "SG Height Map Forward (filter ": lambda t: (
        lambda fw=float(t.name.split("(filter ")[1].split(")")[0]):
        lambda: G.height_map_forward_group(fw))(),
    **{key + " [": _per_image for key in _PER_IMAGE},
}
_HELPERS = {".SG Safe Normal": G.safe_normal_group,
            ".SG Surface Gradient": G.surface_gradient_group,
            ".SG UV Gradients": G.uv_gradients_group,
            ".SG Bump Strength": G.bump_strength_group,
            ".SG Gradient Noise": G.gradient_noise_group,
            ".SG Gradient Noise (Geometry)": lambda: G.gradient_noise_group("GeometryNodeTree")}


def builder_call(tree):
    """A call that rebuilds `tree` (or the group it is Blender's ".001" copy of, which rebuilds
    the copy too), or None when its build cannot be told from the tree."""
    name = _COPY.sub("", tree.name)
    entry = G.BY_NAME.get(name)
    if entry is not None and not entry.image_bound:
        return entry.build
    if name in _HELPERS:
        return _HELPERS[name]
    for prefix, recipe in _BY_PREFIX.items():
        if name.startswith(prefix):
            try:
                return recipe(tree)
            except (ValueError, IndexError):
                return None
    return None


def _foreign_names():
    """Groups of the user's (no stamp) under the name of one of ours: every rebuild that needs
    it would be refused, so the update is refused before it starts."""
    ours = set(G.BY_NAME) | set(_HELPERS)
    return sorted(g.name for g in bpy.data.node_groups
                  if g.library is None and g.name in ours and VERSION_KEY not in g)


def _remove_unused_added(before):
    """Remove the groups the update added that nothing uses: rebuilding a stale copy ("SG
    Decal.001") with no original beside it builds the original too."""
    while True:
        unused = [g for g in bpy.data.node_groups
                  if g.name_full not in before and g.users == 0 and not g.use_fake_user]
        if not unused:
            return
        for group in unused:
            bpy.data.node_groups.remove(group)


def _node_trees():
    """Every local node tree of the file that a group node can be in."""
    owners = (*bpy.data.materials, *bpy.data.worlds, *bpy.data.lights, *bpy.data.linestyles)
    trees = [o.node_tree for o in owners if getattr(o, "node_tree", None) is not None]
    return [t for t in (*trees, *bpy.data.node_groups) if t.library is None]


def _plain(value):
    return value if isinstance(value, (str, int, float, bool)) else tuple(value)


def _move_users(old, new):
    """Point every group node using `old` at `new`, keeping its inputs' values and its links
    by socket name (the two were built apart: their socket identifiers may differ)."""
    for tree in _node_trees():
        for node in [n for n in tree.nodes if getattr(n, "node_tree", None) == old]:
            values = {(s.name, s.type): _plain(s.default_value) for s in node.inputs
                      if hasattr(s, "default_value")}
            into = {s.name: [lk.from_socket for lk in s.links] for s in node.inputs}
            out = {s.name: [lk.to_socket for lk in s.links] for s in node.outputs}
            node.node_tree = new
            for socket in node.inputs:
                if (socket.name, socket.type) in values:    # (a type changed: its default)
                    socket.default_value = values[socket.name, socket.type]
                for source in into.get(socket.name, ()):
                    if not socket.is_linked:
                        tree.links.new(source, socket)
            for socket in node.outputs:
                for target in out.get(socket.name, ()):
                    if not any(lk.from_socket == socket for lk in target.links):
                        tree.links.new(socket, target)


def _gather_renamed(stale):
    """Give each per-image group named otherwise than for the images it holds (by an older
    surfgrad, or an image renamed since) the name it gets now, where that name is free;
    returns ([(group, its old name)] renamed, [(old name, new name)] of those whose new name
    another group holds: their users move to it after the rebuild)."""
    renamed, merged = [], []
    for tree in stale:
        target = renamed_target(tree, any_name=True)
        if target is None:
            continue
        old = tree.name
        if bpy.data.node_groups.get((target, None)) is None:
            tree.name = target
            renamed.append((tree, old))
        else:
            merged.append((old, target))
    return renamed, merged


def update_stale_groups():
    """Rebuild every stale group in place; a per-image group an older surfgrad named
    otherwise takes today's name, or, where a group holds that name already, its users move
    to that group and it is removed. Returns (updated names, [(name, why)] of those left as
    they were). Raises ValueError, with nothing changed, when a group of the user's holds one
    of our names (each rebuild also checks itself first: node_builder)."""
    foreign = _foreign_names()
    if foreign:
        raise ValueError(f"node group(s) {', '.join(map(repr, foreign))} are not "
                         f"surface-gradient groups but hold their names: rename them, then "
                         f"update the groups")
    stale = stale_groups()
    names = [tree.name for tree in stale]        # a merged group is gone after the update
    calls, left = [], []
    for tree in stale:
        call = builder_call(tree)
        reason = G.unavailable_reason(_COPY.sub("", tree.name)) or _unread_image(tree)
        if call is None or reason or renamed_away(tree):
            left.append((tree.name, reason or (
                f"its name is none that surfgrad gives (renamed: yours now, which group it "
                f"is cannot be told); {RENAMED_FIX}" if renamed_away(tree) else
                "its build cannot be told from the group (add it again from the menu)")))
        else:
            calls.append((tree.name, call))
    added = {g.name_full for g in bpy.data.node_groups}
    renamed, merged = _gather_renamed([t for t in stale if t.name in dict(calls)])
    try:
        checked_first(*(call for _, call in calls))   # one refusal: no group changed
    except BaseException:
        for tree, old in renamed:
            tree.name = old
        raise
    for old, target in merged:
        group = bpy.data.node_groups.get((old, None))
        _move_users(group, bpy.data.node_groups.get((target, None)))
        if group.users == int(group.use_fake_user):
            bpy.data.node_groups.remove(group)
    _remove_unused_added(added)
    moved = {old: tree.name for tree, old in renamed} | {
        old: new for old, new in merged if bpy.data.node_groups.get((old, None)) is None}
    still = {g.name for g in stale_groups()}
    skipped = {name for name, _ in left}
    updated = []
    for name in names:
        now = moved.get(name, name)
        if name in skipped:
            continue
        if now in still:
            left.append((name, "its rebuild did not reach it (add the group again from the "
                               "menu)"))
        else:
            updated.append(name if now == name else f"{name} (now {now})")
    return sorted(updated), left


class SURFGRAD_OT_update_groups(bpy.types.Operator):
    """Rebuild this file's surface-gradient groups that an older surfgrad or another Blender \
line built, for this one, keeping every node's values and links"""
    bl_idname = "surfgrad.update_groups"
    bl_label = "Update surfgrad Groups"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        take_notes()
        try:
            with all_or_nothing():
                updated, left = update_stale_groups()
        except (ValueError, RuntimeError) as err:
            self.report({'ERROR'}, str(err))
            report_notes(self)
            return {'CANCELLED'}
        if not updated and not left:
            self.report({'INFO'}, "The surface-gradient groups are up to date")
            return {'CANCELLED'}                 # nothing changed: no undo step
        if not updated:
            # (It reported "Updated 0 ... group(s): " and FINISHED: an undo step of nothing.)
            for name, why in left:
                self.report({'WARNING'}, f"{name!r} left as it was: {why}")
            self.report({'ERROR'}, f"No surface-gradient group was updated ({len(left)} left "
                                   f"as they were: see the warnings)")
            report_notes(self)
            return {'CANCELLED'}
        self.report({'INFO'}, f"Updated {len(updated)} surface-gradient group(s) for Blender "
                              f"{running_line().line}: {', '.join(updated)}")
        for name, why in left:
            self.report({'WARNING'}, f"{name!r} left as it was: {why}")
        report_notes(self)
        return {'FINISHED'}


def shown_trees(context):
    """The node trees a node editor in `context` shows: its tree and the groups entered."""
    space = getattr(context, "space_data", None)
    path = getattr(space, "path", None) if getattr(space, "type", None) == 'NODE_EDITOR' \
        else None
    return [p.node_tree for p in path] if path is not None else []


def draw_stale_warning(layout, context=None):
    """In the sidebar: the stale groups, if any, and the button that updates them; the stale
    groups of libraries, which only their own files can update; current groups edited
    inside."""
    stale = stale_groups()
    updatable = any(not renamed_away(g) for g in stale)      # (a renamed one: rename it back)
    for text, button in ((stale_text(stale), updatable), (linked_stale_text(), False),
                         (edited_text(shown_trees(context)), False)):
        if text:
            box = layout.box()
            for i, line in enumerate(textwrap.wrap(text, 38, break_on_hyphens=False)):
                box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")
            if button:
                box.operator(SURFGRAD_OT_update_groups.bl_idname, icon="FILE_REFRESH")
