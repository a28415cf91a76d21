"""What Cycles runs for a material after its constant folding, counted by Cycles itself.

Cycles' SVM compiler keeps a summary per shader (scene/svm.cpp: "Number of SVM nodes", "Peak
stack usage") and logs it at debug verbosity once the graph is folded, deduplicated and
compiled. This module renders a tiny frame (8x8, 1 sample, Cycles CPU, one thread) in a child
interpreter with that logging switched on and reads the summaries back: a count that does not
depend on timing, so a test can assert that a constant option costs nothing.

How the log is switched on differs per line (the bpy module parses no command line, so
Blender's --debug-cycles and --log do not exist here):
  4.2, 4.5  Cycles logs through glog; GLOG_v=3 in the child's environment shows its work level.
  5.0+      Cycles' own logger (util/log.cpp) forwards to CLOG at the level kept in the global
            ccl::LOG_LEVEL, set once from CLOG at start-up. Nothing public changes it, so the
            child writes LOG_LEVEL_DEBUG into that variable, found by name in the bpy module's
            symbol table (it ships unstripped) and checked to hold a log level before the write.

The unit of the count differs too: up to 5.1 an SVM node is a run of int4 records (a Vector
Math node with a constant operand is 3), from 5.2 the program is a run of 32-bit words
(Cycles 4bb6d4ff0, "Replace uint4 SVM packing with structs"). Compare counts within a line.
"""

import json
import os
import re
import struct
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
MARK = "SVM_COUNTS_RESULT "
TOKEN = "SVMCOUNT_{}"            # each counted material's name while the child renders
CCL_LOG_LEVEL = "_ZN3ccl9LOG_LEVELE"
CCL_DEBUG, CCL_LEVELS = 8, range(0, 10)     # util/log.h: LOG_LEVEL_FATAL 0 .. TRACE 9
_SUMMARY = re.compile(r"Shader name: (SVMCOUNT_\d+)[ \t]*\n[^\n]*?Number of SVM nodes:\s*(\d+)"
                      r"[ \t]*\n[^\n]*?Peak stack usage:\s*(\d+)")


class SvmCountError(RuntimeError):
    """The counts could not be read (the line, the file or the material is named)."""


@dataclass(frozen=True)
class SvmSummary:
    """One material's compiled shader: `nodes` is Cycles' "Number of SVM nodes" (surface,
    bump, volume and displacement programs together), in `unit`s; `peak_stack` its stack
    slots at the deepest point."""
    nodes: int
    peak_stack: int
    unit: str


def unit_for(version):
    """What one SVM count is on Blender `version` (a tuple): "int4" records or "int" words."""
    return "int" if tuple(version[:2]) >= (5, 2) else "int4"


def svm_counts(materials, blend=None, build=None, paths=(), python=None, timeout=300):
    """{material name: SvmSummary} for `materials`, compiled by Cycles in a child interpreter.

    The materials come from `blend` (a .blend path, opened with its scripts off) or from
    `build`, "package.module:function" run in the child on an empty file to make them
    (`paths`: extra folders for the child's sys.path). Each material goes on its own object in
    a scene of its own, so it need not be used in the file. `python`: the interpreter (the
    Blender line) to ask, this one by default. Raises SvmCountError saying why when a count
    cannot be had."""
    materials = list(materials)
    if (blend is None) == (build is None):
        raise ValueError("give exactly one of blend= and build=")
    if not materials or len(set(materials)) != len(materials):
        raise ValueError(f"give distinct material names, not {materials!r}")
    request = {"materials": materials, "blend": str(Path(blend).resolve()) if blend else None,
               "build": build, "paths": [str(p) for p in paths]}
    inherited = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    # GLOG_*: 4.x's glog reads them at start-up (5.x ignores them; see the module doc).
    env = dict(os.environ, GLOG_v="3", GLOG_logtostderr="1",
               PYTHONPATH=os.pathsep.join([str(ROOT), *inherited]))
    cmd = [python or sys.executable, "-m", "surfgrad_addon.harness.bench.svm_counts", "--child",
           json.dumps(request)]
    try:
        proc = subprocess.run(cmd, cwd=str(ROOT), env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, errors="replace",
                              timeout=timeout)
    except subprocess.TimeoutExpired:
        raise SvmCountError(f"the child compiling {materials} took over {timeout} s") from None
    return parse(proc.stdout, materials, proc.returncode)


def parse(output, materials, returncode=0):
    """The summaries in a child's output (its last MARK line names the line and the tokens)."""
    results = [line[len(MARK):] for line in output.splitlines() if line.startswith(MARK)]
    if returncode != 0 or not results:
        tail = "\n".join(output.strip().splitlines()[-15:])
        raise SvmCountError(f"the child compiling {materials} failed (exit {returncode}):\n"
                            f"{tail}")
    result = json.loads(results[-1])
    if result.get("error"):
        raise SvmCountError(result["error"])
    found, names = {}, {TOKEN.format(i): name for i, name in enumerate(materials)}
    for token, nodes, stack in _SUMMARY.findall(output):
        summary = (int(nodes), int(stack))
        if found.setdefault(token, summary) != summary:
            raise SvmCountError(f"Cycles compiled {names.get(token, token)!r} twice with "
                                f"different counts: {found[token]} and {summary}")
    unit = unit_for(result["version"])
    counts = {}
    for i, name in enumerate(materials):
        token = TOKEN.format(i)
        if token not in found:
            raise SvmCountError(f"Blender {result['version_string']}: Cycles logged no "
                                f"compilation summary for material {name!r} (its debug log "
                                f"did not come on, or the material was not compiled)")
        counts[name] = SvmSummary(*found[token], unit)
    return counts


# The child ---------------------------------------------------------------------------------

def _elf_symbol(path, name):
    """(offset from the load address, size) of the data symbol `name` in the ELF64 shared
    library `path`'s .symtab (local symbols included: the ones a module does not export)."""
    import mmap

    import numpy as np
    with open(path, "rb") as f:
        data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise SvmCountError(f"{path} is not a 64-bit little-endian ELF file")
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)
                for i in range(shnum)]
    symtab = next((s for s in sections if s[1] == 2), None)          # SHT_SYMTAB
    if symtab is None:
        raise SvmCountError(f"{path} has no symbol table (a stripped build)")
    strtab = sections[symtab[6]]
    strings = data[strtab[4]:strtab[4] + strtab[5]]
    wanted, key, at = set(), name.encode() + b"\0", 0
    while (at := strings.find(key, at)) >= 0:      # tail-merged names share their ends
        wanted.add(at)
        at += 1
    entry = np.dtype([("name", "<u4"), ("info", "u1"), ("other", "u1"), ("shndx", "<u2"),
                      ("value", "<u8"), ("size", "<u8")])
    syms = np.frombuffer(data[symtab[4]:symtab[4] + symtab[5]], dtype=entry)
    hits = syms[np.isin(syms["name"], sorted(wanted)) & ((syms["info"] & 0xF) == 1)]
    if len(hits) != 1:
        raise SvmCountError(f"{path}: {len(hits)} data symbols named {name}, not one")
    phoff, = struct.unpack_from("<Q", data, 0x20)
    phentsize, phnum = struct.unpack_from("<HH", data, 0x36)
    loads = [struct.unpack_from("<IIQQQQQQ", data, phoff + i * phentsize) for i in range(phnum)]
    first = min(p[3] - p[2] for p in loads if p[0] == 1)             # PT_LOAD: vaddr - offset
    return int(hits[0]["value"]) - first, int(hits[0]["size"])


def _raise_ccl_log_level(library):
    """Set Cycles' ccl::LOG_LEVEL to debug in this process (Blender 5.x; see the docstring)."""
    import ctypes
    if not os.path.exists("/proc/self/maps"):
        raise SvmCountError("Cycles' compilation log can be switched on only on Linux here "
                            "(the bpy module is found in memory through /proc/self/maps)")
    offset, size = _elf_symbol(library, CCL_LOG_LEVEL)
    real = os.path.realpath(library)
    base = None
    with open("/proc/self/maps") as maps:
        for line in maps:
            parts = line.split()
            if len(parts) >= 6 and int(parts[2], 16) == 0 and \
                    os.path.realpath(parts[5]) == real:
                base = int(parts[0].split("-")[0], 16)
                break
    if base is None or size != 4:
        raise SvmCountError(f"{library} is not mapped in this process, or its {CCL_LOG_LEVEL} "
                            f"is {size} bytes")
    level = ctypes.c_int.from_address(base + offset)
    if level.value not in CCL_LEVELS:
        raise SvmCountError(f"{CCL_LOG_LEVEL} in {library} holds {level.value}, not a log level")
    level.value = CCL_DEBUG


def _scene(names):
    """A scene of its own: a camera, one triangle per material, Cycles CPU at its cheapest."""
    import bpy
    scene = bpy.data.scenes.new("svm_counts")
    cam = bpy.data.objects.new("svm_counts_camera", bpy.data.cameras.new("svm_counts_camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = (0.0, 0.0, 5.0)
    for i, name in enumerate(names):
        mesh = bpy.data.meshes.new(f"svm_counts_{i}")
        mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
        mesh.materials.append(bpy.data.materials[name])
        scene.collection.objects.link(bpy.data.objects.new(f"svm_counts_{i}", mesh))
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = 8
    scene.render.resolution_percentage = 100
    scene.render.threads_mode = "FIXED"             # one thread: summaries never interleave
    scene.render.threads = 1
    return scene


def child(request):
    """Make or open the materials, compile them in one tiny render, print the MARK line."""
    import importlib.util
    library = importlib.util.find_spec("bpy").origin
    import bpy
    version = tuple(bpy.app.version)
    result = {"version": version, "version_string": bpy.app.version_string, "error": None}
    try:
        if version >= (5, 0, 0):
            try:
                _raise_ccl_log_level(library)
            except SvmCountError as err:
                raise SvmCountError(f"cannot switch on Cycles' compilation log, so this line "
                                    f"cannot report SVM counts: {err}") from None
        if request["blend"]:
            from ...addon.open_blend import open_mainfile
            open_mainfile(request["blend"])
        else:
            bpy.ops.wm.read_factory_settings(use_empty=True)
            sys.path[:0] = request["paths"]
            module, _, function = request["build"].partition(":")
            getattr(__import__(module, fromlist=[function]), function)()
        missing = [m for m in request["materials"] if m not in bpy.data.materials]
        if missing:
            raise SvmCountError(f"no material named {missing} "
                                f"({request['blend'] or request['build']})")
        for i, name in enumerate(request["materials"]):
            bpy.data.materials[name].name = TOKEN.format(i)     # unique among all shaders
        scene = _scene([TOKEN.format(i) for i in range(len(request["materials"]))])
        bpy.ops.render.render(scene=scene.name)
    except (SvmCountError, ValueError) as err:     # ValueError: BlendOpenError, a bad build
        result["error"] = f"Blender {bpy.app.version_string}: {err}"
    sys.stdout.flush()
    print(MARK + json.dumps(result), flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] != ["--child"]:
        sys.exit("usage: python -m surfgrad_addon.harness.bench.svm_counts --child REQUEST")
    child(json.loads(sys.argv[2]))
