"""A bake that cannot fit the process's address-space limit, refused before it starts.

A farm or a shell may cap a job's address space (`ulimit -v`, SGE's h_vmem). Blender's bake
does not survive running into it: its buffers' allocation fails in C code ("Malloc returns
null ... in bake pixels low poly", then a segmentation fault, exit 139; or std::bad_alloc,
exit 134), with no line of ours and Blender's session folder left in $TMPDIR. So the request
check compares what the bake will at least add with the room the limit leaves.

BYTES_PER_TEXEL is a lower bound, measured on 5.2.3 (peak VmSize during
`bake-normal-map` of a one-object asset, 2-core machine): 2048^2 to 4096^2 added 183
(PNG) to 194 (EXR) bytes a texel. What a bake adds beyond that (thread stacks and malloc
arenas grow with the core count: 0.56 GB here) is not counted, so a bake refused here would
have failed; one close to the limit may still fail in Blender.
"""

import resource

BYTES_PER_TEXEL = 180
GB = 1024 ** 3


def address_space_in_use():
    """This process's virtual size in bytes (Linux /proc), or None where it cannot be read."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def bake_memory_problem(resolution, tiles):
    """None, or the problem when `tiles` maps of resolution^2 cannot fit the soft address-space
    limit (RLIMIT_AS) beside what this process already uses."""
    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    if limit == resource.RLIM_INFINITY:
        return None
    used = address_space_in_use()
    if used is None:
        return None
    need = BYTES_PER_TEXEL * int(resolution) ** 2 * max(1, int(tiles))
    if used + need <= limit:
        return None
    return (f"a {resolution}x{resolution} bake of {tiles} tile(s) needs at least "
            f"{need / GB:.1f} GB of memory beyond the {used / GB:.1f} GB this process uses, "
            f"more than its address-space limit of {limit / GB:.1f} GB (`ulimit -v`, or the "
            f"job's memory limit such as SGE's h_vmem), where Blender's bake would crash: "
            f"raise the limit or bake at a lower --resolution")
