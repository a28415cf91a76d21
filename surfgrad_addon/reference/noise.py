"""3-D gradient noise with an exact analytic gradient, built so that shader nodes can rebuild it.

The lattice gradients come from Blender's White Noise texture (3-D, Color output) evaluated at
the integer corner positions: `2 * color - 1`. That hash is Bob Jenkins' lookup3 on the float
bits of the input (Cycles `util/hash.h`: hash_float3_to_float3), reproduced here bit for bit
in uint32 arithmetic, so a node graph of Floor, Add, White Noise, Dot Product and Math nodes
gives the same lattice. Between the lattice points the noise is Perlin's: corner dot products
blended with the quintic fade 6t^5 - 15t^4 + 10t^3 (C2 everywhere).

From Gustavson's note and the paper's section 4.6: fractal sum, turbulence and a dented
composite g(f) = f^k, all with their gradients through the chain rule.
"""

import numpy as np

from .noise_footprint import FADE_HI, FADE_LO, octave_weight
from .vecmath import as_float, stack_last

_U32 = np.uint32


def _rot(x, k):
    return (x << _U32(k)) | (x >> _U32(32 - k))


def _final(a, b, c):
    # lookup3 final(a, b, c): the same sequence as Cycles' `final` macro.
    c = (c ^ b) - _rot(b, 14)
    a = (a ^ c) - _rot(c, 11)
    b = (b ^ a) - _rot(a, 25)
    c = (c ^ b) - _rot(b, 16)
    a = (a ^ c) - _rot(c, 4)
    b = (b ^ a) - _rot(a, 14)
    c = (c ^ b) - _rot(b, 24)
    return a, b, c


def _mix(a, b, c):
    a = (a - c) ^ _rot(c, 4)
    c = c + b
    b = (b - a) ^ _rot(a, 6)
    a = a + c
    c = (c - b) ^ _rot(b, 8)
    b = b + a
    a = (a - c) ^ _rot(c, 16)
    c = c + b
    b = (b - a) ^ _rot(a, 19)
    a = a + c
    c = (c - b) ^ _rot(b, 4)
    b = b + a
    return a, b, c


def hash_uint3(kx, ky, kz):
    """Cycles' hash_uint3 (Jenkins lookup3) on uint32 arrays."""
    kx, ky, kz = (np.asarray(k, dtype=_U32) for k in (kx, ky, kz))
    init = _U32((0xDEADBEEF + (3 << 2) + 13) & 0xFFFFFFFF)
    a = init + kx
    b = init + ky
    c = init + kz
    return _final(a, b, c)[2]


def hash_uint4(kx, ky, kz, kw):
    """Cycles' hash_uint4 (Jenkins lookup3) on uint32 arrays."""
    kx, ky, kz, kw = (np.asarray(k, dtype=_U32) for k in (kx, ky, kz, kw))
    init = _U32((0xDEADBEEF + (4 << 2) + 13) & 0xFFFFFFFF)
    a, b, c = _mix(init + kx, init + ky, init + kz)
    a = a + kw
    return _final(a, b, c)[2]


def _uint_to_float_incl(h):
    # (float)n * (1.0f / (float)0xFFFFFFFFu); (float)0xFFFFFFFF rounds to 2^32, so the factor
    # is exactly 2^-32 and the product is exact after the uint->float rounding.
    return h.astype(np.float32) * np.float32(2.0 ** -32)


def white_noise_color(p):
    """Blender's White Noise texture, 3-D, Color output, for positions p (..., 3) as float32.

    Returns float32 (..., 3) in [0, 1]: (hash3(p), hash4(p, 1), hash4(p, 2)).
    """
    bits = np.ascontiguousarray(np.asarray(p, dtype=np.float32)).view(_U32)
    x, y, z = bits[..., 0], bits[..., 1], bits[..., 2]
    one = np.full_like(x, np.float32(1.0).view(_U32))
    two = np.full_like(x, np.float32(2.0).view(_U32))
    return np.stack([_uint_to_float_incl(hash_uint3(x, y, z)),
                     _uint_to_float_incl(hash_uint4(x, y, z, one)),
                     _uint_to_float_incl(hash_uint4(x, y, z, two))], axis=-1)


def lattice_gradient(corner):
    """The gradient vector at integer lattice points: 2 * WhiteNoiseColor(corner) - 1."""
    return 2.0 * white_noise_color(corner) - 1.0


def _fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)


def _fade_deriv(t):
    return 30 * t * t * (t * (t - 2) + 1)


_CORNERS = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=np.int8)


def _unique_rows(cells):
    """Distinct rows of an (N, 3) array of integer-valued floats, and each row's index."""
    if len(cells) == 0:
        return cells, np.zeros(0, dtype=np.int64)
    k = cells.astype(np.int64)
    lo = k.min(axis=0)
    span = k.max(axis=0) - lo + 1
    o = k - lo
    # The box's cell count in Python integers: np.prod wraps past 2^63 (cells 2e6 apart on
    # every axis: a 1e5 m mesh at Scale 4) to a negative count, which passed the test below.
    box = int(span[0]) * int(span[1]) * int(span[2])
    if box <= max(4 * len(k), 1 << 16):
        # Few cells in a small box (a block of texels): mark them in a dense table, no sort.
        key = (o[:, 0] * span[1] + o[:, 1]) * span[2] + o[:, 2]
        present = np.zeros(box, dtype=bool)
        present[key] = True
        first_key = np.nonzero(present)[0]
        index = np.cumsum(present) - 1
        cz = first_key % span[2]
        cy = (first_key // span[2]) % span[1]
        cx = first_key // (span[2] * span[1])
        unique = (np.stack([cx, cy, cz], axis=-1) + lo).astype(cells.dtype)
        return unique, index[key]
    if np.all(span <= (1 << 21)):
        # Pack three 21-bit offsets into one int64 key: a 1-D unique is much faster.
        key = (o[:, 0] << 42) | (o[:, 1] << 21) | o[:, 2]
        _, first, which = np.unique(key, return_index=True, return_inverse=True)
    else:
        _, first, which = np.unique(k, axis=0, return_index=True, return_inverse=True)
    return cells[first], which.reshape(-1)


def gradient_noise(p):
    """Perlin-style gradient noise at p (..., 3). Returns (value (...,), gradient (..., 3)).

    value = sum over the 8 cell corners c of w_c(fade(f)) * dot(g_c, f - c), with f = p -
    floor(p); the gradient is its exact derivative (product rule over the trilinear weights).
    Computed component by component on contiguous rows (vecmath's layout).
    """
    (p,) = as_float(p)
    shape = p.shape[:-1]
    q = p.reshape(-1, 3)
    cell = np.floor(q)
    f = [q[:, a] - cell[:, a] for a in range(3)]
    u = [_fade(fa) for fa in f]
    du = [_fade_deriv(fa) for fa in f]
    # Hash each distinct cell's corners once: dense samples share few cells.
    unique_cells, which = _unique_rows(cell)
    if len(q) == 0:
        return np.zeros(shape, dtype=p.dtype), np.zeros(shape + (3,), dtype=p.dtype)
    # All corners of the distinct cells in one hash call: (8, 3, cells) gradient rows.
    # cell + c also turns floor(-0.0) = -0.0 into +0.0, as a node graph's Add does.
    corners = (unique_cells[:, None, :] + _CORNERS).reshape(-1, 3)
    lattice = np.ascontiguousarray(lattice_gradient(corners).astype(p.dtype)
                                   .reshape(len(unique_cells), 8, 3).transpose(1, 2, 0))
    d = [(f[a], f[a] - 1) for a in range(3)]        # f - c per axis
    ux, uy, uz = u

    def lerp(a, b, t):
        b -= a
        b *= t
        b += a
        return b

    # value = sum_c w_c dot_c with trilinear weights w_c: lerps along x, then y, then z.
    # gradient = sum_c w_c g_c + sum_c dot_c grad(w_c); the first sum is the same trilinear
    # interpolation of the corner gradients, the second per axis du times the interpolation
    # (over the other two axes) of the differences of dot_c along that axis.
    along_x, diff_x, g_x = {}, {}, {}
    for j in (0, 1):
        for k in (0, 1):
            pair_dot, pair_g = [], []
            for i in (0, 1):
                g = np.take(lattice[(i << 2) | (j << 1) | k], which, axis=1)
                dotted = g[0] * d[0][i]
                dotted += g[1] * d[1][j]
                dotted += g[2] * d[2][k]
                pair_dot.append(dotted)
                pair_g.append(g)
            diff_x[j, k] = pair_dot[1] - pair_dot[0]
            along_x[j, k] = pair_dot[0] + ux * diff_x[j, k]
            g_x[j, k] = lerp(pair_g[0], pair_g[1], ux)
    along_y = {k: along_x[0, k] + uy * (along_x[1, k] - along_x[0, k]) for k in (0, 1)}
    dz = along_y[1] - along_y[0]
    value = along_y[0] + uz * dz
    grad_w = lerp(lerp(g_x[0, 0], g_x[1, 0], uy), lerp(g_x[0, 1], g_x[1, 1], uy), uz)
    dy0 = along_x[1, 0] - along_x[0, 0]
    dy1 = along_x[1, 1] - along_x[0, 1]
    ex0 = lerp(diff_x[0, 0], diff_x[1, 0], uy)
    ex1 = lerp(diff_x[0, 1], diff_x[1, 1], uy)
    grad = [grad_w[0] + du[0] * lerp(ex0, ex1, uz),
            grad_w[1] + du[1] * lerp(dy0, dy1, uz),
            grad_w[2] + du[2] * dz]
    return value.reshape(shape), stack_last(grad).reshape(shape + (3,))


def _octave_amplitude(amp, freq, footprint, fade):
    """amp, or amp times the octave's footprint weight (reference/noise_footprint.py) as a
    (..., 1) column when a footprint is given."""
    if footprint is None:
        return amp
    return amp * octave_weight(freq, footprint, *fade)[..., None]


def fractal_sum(p, octaves=4, lacunarity=2.0, gain=0.5, footprint=None,
                fade=(FADE_LO, FADE_HI)):
    """Perlin's fractal sum: sum_i gain^i * noise(lacunarity^i * p), with its gradient.

    footprint (shape p.shape[:-1], in p's units): fade each octave finer than it by
    w_i = 1 - smoothstep(fade[0], fade[1], lacunarity^i * footprint) (noise_footprint.py);
    None sums every octave at full weight, as before."""
    (p,) = as_float(p)
    value = np.zeros(p.shape[:-1], dtype=p.dtype)
    grad = None
    for i in range(octaves):
        freq = lacunarity ** i
        amp = _octave_amplitude(gain ** i, freq, footprint, fade)
        v, g = gradient_noise(p * freq)
        grad = np.zeros_like(g) if grad is None else grad       # the noise's layout
        value += (amp if footprint is None else amp[..., 0]) * v
        g *= amp * freq             # chain rule: d/dp noise(freq p) = freq * grad
        grad += g
    if grad is None:
        grad = np.zeros(p.shape, dtype=p.dtype)
    return value, grad


def turbulence(p, octaves=4, lacunarity=2.0, gain=0.5, footprint=None,
               fade=(FADE_LO, FADE_HI)):
    """Perlin's turbulence: sum_i gain^i * |noise(lacunarity^i * p)|, with its gradient
    (sign(noise) * gradient; undefined only on the zero set of each octave). footprint and
    fade as in fractal_sum."""
    (p,) = as_float(p)
    value = np.zeros(p.shape[:-1], dtype=p.dtype)
    grad = None
    for i in range(octaves):
        freq = lacunarity ** i
        amp = _octave_amplitude(gain ** i, freq, footprint, fade)
        v, g = gradient_noise(p * freq)
        grad = np.zeros_like(g) if grad is None else grad       # the noise's layout
        value += (amp if footprint is None else amp[..., 0]) * np.abs(v)
        grad += (amp * freq) * np.sign(v)[..., None] * g
    if grad is None:
        grad = np.zeros(p.shape, dtype=p.dtype)
    return value, grad


def dented(p, k=3.0, octaves=4, lacunarity=2.0, gain=0.5):
    """The dented composite of section 4.6: g(turbulence) with g(x) = x^k, and its gradient
    by (g o f)' = g'(f) f'."""
    t, gt = turbulence(p, octaves, lacunarity, gain)
    return t ** k, (k * t ** (k - 1))[..., None] * gt
