"""A bake that cannot fit the process's memory, refused before it starts.

A farm or a shell may cap a job's address space (`ulimit -v`, SGE's h_vmem). Blender's bake
does not survive running into it: its buffers' allocation fails in C code ("Malloc returns
null ... in bake pixels low poly", then a segmentation fault, exit 139; or std::bad_alloc,
exit 134), with no line of ours and Blender's session folder left in $TMPDIR. A bake larger
than the machine's memory (or its container's limit) is ended by the kernel's OOM killer
(SIGKILL: no line either). So the request check compares what the bake will at least add
with the room the limit, and the machine, leave.

BYTES_PER_TEXEL is a lower bound, measured on 5.2.3 (`bake-normal-map` of a one-object
asset, 2-core machine): from 2048^2 to 4096^2 the peak virtual size grew by 183 (PNG) to 194
(EXR) bytes a texel, the peak resident size by 185 to 196. What a bake adds beyond that
(thread stacks and malloc arenas, which grow with the core count: 0.56 GB here) is not
counted, so a bake refused here would have failed; one close to the limit may still fail.
Each further UDIM tile adds much less (its image and pixel buffers, not the bake's working
set): peak resident size of one, two and four tiles at 1024^2 and 2048^2 on 5.2.3, 55 bytes a
texel for each tile after the first (BYTES_PER_FURTHER_TILE_TEXEL, rounded down); counted at
the first tile's 180 they made a 10-tile 4096^2 bake need 28 GB where it needs about 10.

Whatever its size, a bake also takes address space for Cycles' threads (stacks, malloc
arenas): a 64^2 bake crashed with 134 MB (5.2.3) and 257 MB (5.0.1) of room left beyond what
the process held at the check (2 cores; more threads take more), so BYTES_PER_BAKE, rounded
down, is counted against the address-space limit too. And before any check can run, loading
Blender's module and a .blend takes most of that limit: under 1.5 GB a 64^2 bake segfaulted
(5.2, 5.0, 4.5), or on 4.2 spun for good in OpenBLAS's retries of a failed allocation (a
SIGTERM did not end it), with no line; at the check the process held 1.6 to 1.7 GB on every
line. START_BYTES is that floor, checked before Blender's module loads (start_problem).
"""

import resource

BYTES_PER_TEXEL = 180
BYTES_PER_FURTHER_TILE_TEXEL = 50
# An image the bake reads, per texel of its file, at least: Blender's buffer (RGBA, float or
# bytes) and one more copy: the check's of a float image's pixels (float_pixels, one image at
# a time), and Cycles' for the bake (half floats at the least, or bytes). Measured on 5.2.3: an
# 8192^2 float EXR raised a 256^2 bake's peak resident size by 2.2 GB (32 bytes a texel), and
# under `ulimit -v` 2.5 GB Blender's load of it crashed (exit 139) before this was counted.
IMAGE_BYTES_PER_TEXEL = {True: 16, False: 4}            # Blender's buffer: float, bytes
CHECK_COPY_BYTES_PER_TEXEL = 16                          # float_pixels' copy (float RGBA)
CYCLES_BYTES_PER_TEXEL = {True: 8, False: 4}             # Cycles' copy: half at least, bytes
BYTES_PER_BAKE = 128 * 1024 ** 2
START_BYTES = 1536 * 1024 ** 2
GB = 1024 ** 3
# cgroup memory limits (a container's, a scheduler's job): v2, then v1; "max" or a huge
# number means none.
CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")


def _status(key):
    """A "key: N kB" line of /proc/self/status in bytes, or None where it cannot be read."""
    return _kb_line("/proc/self/status", key)


def _kb_line(path, key):
    try:
        with open(path) as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def address_space_in_use():
    """This process's virtual size in bytes (Linux /proc), or None."""
    return _status("VmSize")


def resident_in_use():
    """This process's resident size in bytes (Linux /proc), or None."""
    return _status("VmRSS")


def machine_memory():
    """(bytes, what) of the memory this process can have at most: the machine's memory and
    swap, or its cgroup's limit where lower; None where it cannot be read."""
    total, swap = _kb_line("/proc/meminfo", "MemTotal"), _kb_line("/proc/meminfo", "SwapTotal")
    if total is None:
        return None
    best = (total + (swap or 0), f"this machine's {total / GB:.1f} GB of memory and "
                                 f"{(swap or 0) / GB:.1f} GB of swap")
    for path in CGROUP_LIMITS:
        try:
            with open(path) as f:
                value = int(f.read().strip())
        except (OSError, ValueError):
            continue
        if value < best[0]:
            best = (value, f"the memory limit of its control group ({value / GB:.1f} GB, "
                           f"{path}: a container's or the job's)")
    return best


def bake_memory_problem(resolution, tiles, images=None):
    """None, or the problem when `tiles` maps of resolution^2, and the images it reads
    (`images`: an ImagesMemory, or None), cannot fit the soft address-space limit (RLIMIT_AS)
    beside what this process already uses, or the machine's memory."""
    maps = int(resolution) ** 2 * (BYTES_PER_TEXEL
                                   + BYTES_PER_FURTHER_TILE_TEXEL * (max(1, int(tiles)) - 1))
    need, reading, fix = maps, "", ""
    if images is not None and images.count:
        need = max(maps + images.baked, images.checked)
        reading = f" reading {images.what}"
        # Smaller images are a fix only where the images take a real part of the need.
        fix = " or from smaller images" if need - maps >= need / 10 else ""
    return memory_problem(need, f"a {resolution}x{resolution} bake of {tiles} tile(s){reading}",
                          "bake", fix)


def memory_problem(need, what, verb, also=""):
    """None, or the problem when `need` bytes more cannot fit the soft address-space limit
    beside what this process uses, or the machine's memory; `what` needs them, the fix says
    to `verb` at a lower --resolution (`also`: what else would do)."""
    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    used = address_space_in_use()
    if limit != resource.RLIM_INFINITY and used is not None and \
            used + need + BYTES_PER_BAKE > limit:
        return (f"{what} needs at least {(need + BYTES_PER_BAKE) / GB:.1f} GB of memory "
                f"beyond the {used / GB:.1f} GB this process uses, more than its address-"
                f"space limit of {limit / GB:.1f} GB (`ulimit -v`, or the job's memory limit "
                f"such as SGE's h_vmem), where Blender's bake would crash: raise the limit or "
                f"{verb} at a lower --resolution{also}")
    machine, resident = machine_memory(), resident_in_use()
    if machine is not None and resident is not None and resident + need > machine[0]:
        return (f"{what} needs at least {need / GB:.1f} GB of memory beyond the "
                f"{resident / GB:.1f} GB this process holds, more than {machine[1]}, "
                f"where the system would kill the bake: {verb} at a lower --resolution{also}, "
                f"or on a machine with more memory")
    return None


def start_problem():
    """None, or the problem when the soft address-space limit is below START_BYTES: too
    little to load Blender's module and bake anything (call it before bpy is imported)."""
    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    if limit == resource.RLIM_INFINITY or limit >= START_BYTES:
        return None
    return (f"the address-space limit of {limit / GB:.2f} GB (`ulimit -v`, or the job's "
            f"memory limit such as SGE's h_vmem) is below the {START_BYTES / GB:.1f} GB that "
            f"loading Blender and a .blend takes before anything is baked, where Blender "
            f"would crash: raise the limit")
