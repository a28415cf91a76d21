"""The reference's MikkTSpace mesh where the line has no float corner normals (4.2): a temporary
triangle mesh whose smooth fans are the groups of corners Cycles welds (harness/mesh_data.py).

MikkTSpace welds corners whose position, normal and UV are bitwise equal. Without float normals
the temporary mesh's normals are short pairs decoded once per smooth fan, so corners weld there
only when they share a fan. A fan is the corners round a vertex joined through edges of two
faces; Blender splits it at an edge of three or more faces (a Mirror whose mesh crosses its plane
meets the copy there) and ends it at an edge of one face. This mesh joins them again:

- the faces on an edge of more than two are paired into edges of two (duplicate edges between
  the same vertices, opposite winding), the pairs chosen vertex by vertex so that each vertex's
  corners of one normal make one fan;
- where a vertex's corners of one normal still make several fans, each ending in an edge of one
  face, an extra triangle joins the end of one to the start of the next. Its UVs lie outside
  every real UV, so MikkTSpace welds none of its corners to a real one and the real tangents do
  not see it; its corners take the normals of the corners they join.

The decoded normals are the encoding's (within ~1e-3 of Cycles' floats); the welding is Cycles'.
"""

import itertools

import numpy as np

MAX_PAIRINGS = 24          # pairings tried per edge (an edge of 4 faces has 2)


def fan_mesh(bpy, positions, triangles, values, flat):
    """(mesh, extra triangles (X, 3) vertex indices, their corner normals (X, 3, 3)), or None
    where nothing is paired or joined (the plain triangle mesh does as well): the temporary
    mesh of `triangles` (T, 3) over `positions` with its non-manifold edges paired and its
    split fans joined, for corner normals `values` (T, 3, 3) float32 (what the fans must hold;
    `flat` (T,) the flat triangles, whose corners keep their face's normal). Its first 3T
    corners are the triangles' in order, the extra triangles' follow. Normals and UVs are the
    caller's to set."""
    tris = np.asarray(triangles, dtype=np.int64)
    t = len(tris)
    flat = np.zeros(t, dtype=bool) if flat is None else np.asarray(flat, dtype=bool)
    start = tris.reshape(-1)                              # side s runs from corner s ...
    end = tris[:, [1, 2, 0]].reshape(-1)                  # ... to corner nxt[s]
    nxt = np.arange(3 * t).reshape(-1, 3)[:, [1, 2, 0]].reshape(-1)
    prv = np.arange(3 * t).reshape(-1, 3)[:, [2, 0, 1]].reshape(-1)
    normal = normal_classes(values)
    key = np.minimum(start, end) * len(positions) + np.maximum(start, end)
    _, edge_of_side, count = np.unique(key, return_inverse=True, return_counts=True)
    edge_of_side = edge_of_side.reshape(-1)
    sides = _Sides(start, end, nxt, normal)
    crowded = np.flatnonzero(count[edge_of_side] > 2)
    pairs = _pair_crowded(sides, edge_of_side, crowded)
    edges, corner_edge = _edges(start, end, edge_of_side, count, pairs)
    extra, extra_normals, corner_edge, edges = _bridges(sides, prv, values, flat, edges,
                                                        corner_edge)
    if not pairs and len(extra) == 0:
        return None                   # the plain triangle mesh's fans are already Cycles' welds
    all_tris = np.concatenate([tris, extra.reshape(-1, 3)]).astype(np.int64)
    mesh = bpy.data.meshes.new(".surfgrad_tangents")
    try:
        _fill(mesh, positions, edges, corner_edge, all_tris)
    except BaseException:
        bpy.data.meshes.remove(mesh)      # a failed fill leaves no temporary mesh behind
        raise
    return mesh, extra.reshape(-1, 3), extra_normals.reshape(-1, 3, 3)


def _fill(mesh, positions, edges, corner_edge, all_tris):
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", np.asarray(positions, dtype=np.float32).reshape(-1))
    mesh.edges.add(len(edges))
    mesh.edges.foreach_set("vertices", np.asarray(edges, dtype=np.int32).reshape(-1))
    mesh.loops.add(3 * len(all_tris))
    mesh.loops.foreach_set("vertex_index", all_tris.reshape(-1).astype(np.int32))
    mesh.loops.foreach_set("edge_index", np.asarray(corner_edge, dtype=np.int32))
    mesh.polygons.add(len(all_tris))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(all_tris), 3, dtype=np.int32))
    mesh.update()                 # no validate(): it would merge the paired edges again


def normal_classes(values):
    """(N,) int64 for the N float32 normals `values` (..., 3): equal exactly where their bits
    are (-0 taken as 0)."""
    bits = (np.asarray(values, dtype=np.float32).reshape(-1, 3) + np.float32(0.0)).view(np.uint32)
    order = np.lexsort(bits.T[::-1])
    step = np.any(bits[order][1:] != bits[order][:-1], axis=1)
    classes = np.empty(len(bits), dtype=np.int64)
    classes[order] = np.concatenate([[0], np.cumsum(step)])
    return classes


class _Sides:
    """The triangles' sides: side s runs from corner s (vertex start[s]) to corner nxt[s]
    (vertex end[s]); normal[c] the normal class of corner c."""

    def __init__(self, start, end, nxt, normal):
        self.start, self.end, self.nxt, self.normal = start, end, nxt, normal

    def joins(self, s1, s2):
        """The pairs of corners (at start[s1], at end[s1]) that sides s1, s2 join as one edge
        of two faces, or None where they cannot: the same direction (a flipped face) or
        different normals at either end (a sharp edge)."""
        if self.start[s1] != self.end[s2]:
            return None
        here, there = (s1, self.nxt[s2]), (self.nxt[s1], s2)
        if self.normal[here[0]] != self.normal[here[1]] or \
                self.normal[there[0]] != self.normal[there[1]]:
            return None
        return here, there


def _pair_crowded(sides, edge_of_side, crowded):
    """{edge: [(s1, s2), ...]}: the sides of each edge of more than two faces paired so that the
    corners of one normal round each vertex make one fan: vertex by vertex (breadth first along
    such edges), each picks the pairings of its undecided edges that leave it fewest fans."""
    if len(crowded) == 0:
        return {}
    by_edge = {}
    for s in crowded.tolist():
        by_edge.setdefault(int(edge_of_side[s]), []).append(s)
    options = {e: _pairings(sides, ss) for e, ss in by_edge.items()}
    pairs = {e: opts[0] for e, opts in options.items()}
    ends = {e: (int(sides.start[ss[0]]), int(sides.end[ss[0]])) for e, ss in by_edge.items()}
    at = {}
    for e, (u, v) in ends.items():
        at.setdefault(u, []).append(e)
        at.setdefault(v, []).append(e)
    # The corners at each such vertex and the sides of two faces that join them there.
    touching = np.isin(sides.start, list(at)) | np.isin(sides.end, list(at))
    local = {}
    for s in np.flatnonzero(touching).tolist():
        e = int(edge_of_side[s])
        for v in (int(sides.start[s]), int(sides.end[s])):
            if v in at:
                local.setdefault(v, {}).setdefault(e, []).append(s)

    def fans(v):
        """Extra fans at v: fans of one normal beyond the first."""
        parent = {}
        for e, ss in local[v].items():
            chosen = pairs.get(e) or ([tuple(ss)] if len(ss) == 2 else [])
            for s1, s2 in chosen:
                joined = sides.joins(s1, s2) or sides.joins(s2, s1)
                if joined:
                    a, b = joined[0] if sides.start[joined[0][0]] == v else joined[1]
                    parent[_root(parent, a)] = _root(parent, b)
        corners = {s if sides.start[s] == v else int(sides.nxt[s])
                   for ss in local[v].values() for s in ss}
        groups = {}
        for c in corners:
            groups.setdefault(int(sides.normal[c]), set()).add(_root(parent, c))
        return sum(len(g) - 1 for g in groups.values())

    decided, seen = set(), set()
    for first in sorted(at):
        if first in seen:
            continue
        queue = [first]
        seen.add(first)
        while queue:
            v = queue.pop(0)
            free = [e for e in at[v] if e not in decided]
            best = None
            for combo in itertools.islice(itertools.product(*(options[e] for e in free)), 256):
                pairs.update(zip(free, combo))
                cost = fans(v)
                if best is None or cost < best[0]:
                    best = (cost, combo)
            if free:
                pairs.update(zip(free, best[1]))
                decided.update(free)
            for e in at[v]:
                for w in ends[e]:
                    if w not in seen:
                        seen.add(w)
                        queue.append(w)
    return pairs


def _root(parent, c):
    parent.setdefault(c, c)
    while parent[c] != c:
        parent[c] = parent[parent[c]]
        c = parent[c]
    return c


def _pairings(sides, ss):
    """Up to MAX_PAIRINGS ways to pair the sides `ss` of one edge in opposite directions."""
    forward = [s for s in ss if sides.start[s] < sides.end[s]]
    backward = [s for s in ss if sides.start[s] > sides.end[s]]
    if len(forward) < len(backward):
        forward, backward = backward, forward
    return list(itertools.islice(([tuple(p) for p in zip(perm, backward)]
                                  for perm in itertools.permutations(forward, len(backward))),
                                 MAX_PAIRINGS))


def _edges(start, end, edge_of_side, count, pairs):
    """(edges (E, 2), corner_edge (3T,)): one edge per vertex pair of at most two faces, one per
    chosen pair and one per unpaired side of a crowded pair."""
    first = np.full(len(count), -1, dtype=np.int64)
    first[edge_of_side[::-1]] = np.arange(len(edge_of_side))[::-1]
    plain = count <= 2
    edges = [np.stack([start[first[plain]], end[first[plain]]], axis=1)]
    edge_index = np.full(len(count), -1, dtype=np.int64)
    edge_index[plain] = np.arange(int(plain.sum()))
    corner_edge = edge_index[edge_of_side]
    extra = []
    n = int(plain.sum())
    for e, chosen in pairs.items():
        used = set()
        for s1, s2 in chosen:
            corner_edge[[s1, s2]] = n
            extra.append((start[s1], end[s1]))
            used.update((s1, s2))
            n += 1
        for s in np.flatnonzero(edge_of_side == e).tolist():
            if s not in used:
                corner_edge[s] = n
                extra.append((start[s], end[s]))
                n += 1
    if extra:
        edges.append(np.array(extra, dtype=np.int64))
    return np.concatenate(edges), corner_edge


def _bridges(sides, prv, values, flat, edges, corner_edge):
    """Extra triangles joining the fans of one normal round a vertex that the edges leave apart:
    (triangles (X*3,), their corner normals (X*3, 3), corner_edge and edges with theirs)."""
    n_corners = len(corner_edge)
    uses = np.bincount(corner_edge, minlength=len(edges))
    parent = np.arange(n_corners)
    # Corners joined across an edge of two faces (opposite winding, one normal at both ends).
    order = np.argsort(corner_edge, kind="stable")
    at = np.searchsorted(corner_edge[order], np.flatnonzero(uses == 2))
    s1, s2 = order[at], order[at + 1]
    swap = sides.start[s1] != sides.end[s2]
    s1, s2 = np.where(swap, s2, s1), np.where(swap, s1, s2)
    here, there = np.stack([s1, sides.nxt[s2]], 1), np.stack([sides.nxt[s1], s2], 1)
    normal = sides.normal
    ok = ((sides.start[s1] == sides.end[s2]) & (normal[here[:, 0]] == normal[here[:, 1]])
          & (normal[there[:, 0]] == normal[there[:, 1]]) & ~flat[s1 // 3] & ~flat[s2 // 3])
    links = np.concatenate([here[ok], there[ok]])
    while len(links):                                     # labels: the least corner of a fan
        low = np.minimum(parent[links[:, 0]], parent[links[:, 1]])
        new = parent.copy()
        np.minimum.at(new, links[:, 0], low)
        np.minimum.at(new, links[:, 1], low)
        new = new[new]
        if np.array_equal(new, parent):
            break
        parent = new
    # The (vertex, normal) groups of smooth corners in more than one fan (sorted by group, then
    # fan: a group holds more than one fan where its first and last fans differ).
    vertex = sides.start
    smooth = np.flatnonzero(~np.repeat(flat, 3))          # flat corners keep their own normal
    if len(smooth) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3), dtype=np.float32), corner_edge, edges
    group = vertex[smooth] * (int(normal.max()) + 1) + normal[smooth]
    order = np.lexsort((parent[smooth], group))
    corners, group = smooth[order], group[order]
    first = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    last = np.r_[first[1:], len(group)]
    split = np.flatnonzero(parent[corners[first]] != parent[corners[last - 1]])
    extra, extra_normals = [], []
    if len(split) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3), dtype=np.float32), corner_edge, edges
    corner_edge = corner_edge.tolist()
    edges = [tuple(e) for e in edges.tolist()]
    values = np.asarray(values, dtype=np.float32).reshape(-1, 3)
    for g in split.tolist():
        members = corners[first[g]:last[g]]
        v = int(vertex[members[0]])
        fan_ends = []
        for label in np.unique(parent[members]).tolist():
            fan = members[parent[members] == label].tolist()
            out = [c for c in fan if uses[corner_edge[c]] == 1]
            into = [c for c in fan if uses[corner_edge[prv[c]]] == 1]
            fan_ends.append((out[0] if out else None, into[0] if into else None))
        # Chain them: fans without a free start first, without a free end last.
        fan_ends.sort(key=lambda f: (f[1] is not None, f[0] is None))
        for (out, _), (_, into) in zip(fan_ends, fan_ends[1:]):
            if out is None or into is None:
                continue
            x, y = int(sides.end[out]), int(sides.start[prv[into]])
            if x == y:
                continue
            # (x, v, y): x -> v against `out` (v -> x), v -> y against the side into `into`.
            extra.extend((x, v, y))
            corner_edge.extend((corner_edge[out], corner_edge[prv[into]], len(edges)))
            edges.append((y, x))
            extra_normals.extend((values[sides.nxt[out]], values[out], values[prv[into]]))
            uses[corner_edge[out]] += 1
            uses[corner_edge[prv[into]]] += 1
    return (np.array(extra, dtype=np.int64),
            np.array(extra_normals, dtype=np.float32).reshape(-1, 3),
            np.array(corner_edge, dtype=np.int64), np.array(edges, dtype=np.int64))
