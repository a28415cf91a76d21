"""The batch's plan, before anything runs: its options and settings checked (settings files,
the output pattern, the asset list), each asset's settings and output name, the hashes that
tell an unchanged asset (skipped unless forced), and the time a worker may take."""

import fnmatch
import hashlib
import json
import os
import re
from pathlib import Path

from ...reference import tiles as T
from .. import bake_request as BR
from .. import number_options as NO
from .. import normal_bake as NB
from ..bake_target import not_a_mesh

SETTING_KEYS = ("uv_map", "space", "resolution", "samples", "margin", "depth", "allow_partial")
DEFAULTS = {"uv_map": None, "space": "tangent", "resolution": NB.DEFAULT_RESOLUTION, "samples": 1,
            "margin": 16, "depth": None, "allow_partial": False}
NOT_HASHED = ("allow_partial",)            # settings that change no texel of the map
TOKENS = ("{file}", "{object}", "{uv}")
BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")   # plain, gzip, zstd
SCAN_TIMEOUT_S = 600.0                      # a worker's scan of one file, unless told
BAKE_TIMEOUT_S = 300.0                      # a worker's bake: this plus 10 s per million
TEXEL_SAMPLES_PER_S = 1e5                   # texel-samples (about 1/30 of one loaded core)


class BatchError(ValueError):
    """Bad input for the whole batch (not one asset's): names the thing and the fix."""


# Inputs ----------------------------------------------------------------------------------------

def blend_problem(path):
    """None if `path` is a readable .blend file, else what is wrong with it."""
    path = Path(path)
    if not path.exists():
        return f"{path}: no such file"
    if path.is_dir():
        return f"{path} is a folder: give .blend files"
    if path.suffix.lower() != ".blend":
        return f"{path} is not a .blend file (give Blender files)"
    if not path.is_file():      # a named pipe or device would block the read below forever
        return f"{path} is not a regular file (a pipe or device?): give .blend files"
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as err:
        return f"{path} cannot be read ({err.strerror}): check its permissions"
    if not head.startswith(BLEND_MAGIC):
        return f"{path} is named .blend but is not a Blender file (damaged, or another format)"
    return None


def sha256_file(path, chunk=1 << 20):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def _read_text(path, what, fix):
    """A UTF-8 text file's text, or a BatchError naming `what` it is and the fix. A leading
    byte-order mark (Windows editors, PowerShell) is dropped, not read as part of a path."""
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as err:
        raise BatchError(f"{what} {path} is not UTF-8 text ({err.reason} at byte "
                         f"{err.start}); {fix}") from None
    except OSError as err:
        raise BatchError(f"{what} {path} cannot be read ({err.strerror}); check its "
                         f"permissions") from None


def load_settings_file(path):
    """{"defaults": {...}, "assets": {PATTERN: {...}}}: PATTERN matches "file.blend:Object",
    "file.blend" or "Object" (shell wildcards); later matches override earlier ones."""
    if Path(path).is_dir():
        raise BatchError(f"settings file {path} is a folder; give the JSON settings file")
    if Path(path).exists() and not Path(path).is_file():
        raise BatchError(f"settings file {path} is not a regular file; give the JSON settings "
                         f"file")
    if not Path(path).exists():
        raise BatchError(f"settings file {path}: no such file")
    text = _read_text(path, "settings file", "save it as UTF-8 JSON")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise BatchError(f"settings file {path} is not valid JSON ({err})") from None
    if not isinstance(data, dict) or set(data) - {"defaults", "assets"}:
        raise BatchError(f"settings file {path}: use an object with 'defaults' and/or 'assets'")
    if not isinstance(data.get("assets", {}), dict):
        raise BatchError(f"settings file {path}: 'assets' must be an object of "
                         f"\"PATTERN\": {{settings}}")
    problems = []
    for where, block in [("defaults", data.get("defaults", {}))] + \
            [(f"assets[{k!r}]", v) for k, v in data.get("assets", {}).items()]:
        if not isinstance(block, dict):
            problems.append(f"settings file {path}: {where} must be an object")
            continue
        # Every value is checked before any file is opened: a bad one bakes nothing.
        problems += BR.settings_problems(block, f"settings file {path}: {where}")
    if problems:
        raise BatchError(joined(problems))
    return data


def joined(problems):
    return problems[0] if len(problems) == 1 else \
        f"{len(problems)} problems:\n  - " + "\n  - ".join(problems)


def asset_settings(defaults, overrides, blend_name, object_name):
    """The settings of one asset: defaults, then every matching override in order."""
    out = dict(DEFAULTS)
    out.update({k: v for k, v in (defaults or {}).items() if v is not None})
    keys = (f"{blend_name}:{object_name}", blend_name, object_name)
    for pattern, block in (overrides or {}).items():
        if any(fnmatch.fnmatchcase(k, pattern) for k in keys):
            out.update(block)
    return out


_UNSAFE = re.compile(r'[\\/:*?"<>|\x00-\x1f]')


def _safe(name):
    """A name as a file-name part (no folder separators or characters Windows refuses; not
    '.' or '..', which as a whole folder name would put the map in another folder)."""
    safe = _UNSAFE.sub("_", name).strip() or "_"
    return "_" * len(safe) if set(safe) == {"."} else safe


def check_pattern(pattern):
    """The output pattern's problems, before anything runs."""
    pattern = str(pattern)
    problem = NB.blend_relative_problem(pattern, "output pattern")
    if problem:
        raise BatchError(problem)
    name = Path(pattern).name
    if not name:
        raise BatchError(f"output pattern {pattern!r} ends in a folder: give a file name")
    if Path(name).suffix.lower() not in NB.FORMATS:
        raise BatchError(f"output pattern {pattern!r}: end it in .png or .exr")
    left = NB.BRACE_TOKEN.findall(pattern.replace("{file}", "").replace("{object}", "")
                      .replace("{uv}", ""))
    if left:
        raise BatchError(f"output pattern {pattern!r}: unknown token {left[0]}; the tokens are "
                         f"{', '.join(TOKENS)} and {NB.UDIM_TOKEN}")
    problem = NB.udim_token_problem(pattern, "output pattern")
    if problem:
        raise BatchError(problem)
    return pattern


_TOKEN = re.compile("|".join(map(re.escape, TOKENS)))


def expand(pattern, blend_name, object_name, uv_map):
    """The output name of one asset (keeps <UDIM>). The tokens are filled in one pass: a name
    holding a token's text (an object named '{uv}') is not filled in again."""
    stem = Path(blend_name).stem if blend_name else "untitled"
    values = {"{file}": _safe(stem), "{object}": _safe(object_name), "{uv}": _safe(uv_map)}
    return _TOKEN.sub(lambda m: values[m.group()], str(pattern))


def settings_hash(settings, output, blender_version, version):
    settings = {k: v for k, v in settings.items() if k not in NOT_HASHED}
    blob = json.dumps({"settings": settings, "output": str(output), "blender": blender_version,
                       "surfgrad": version}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def input_hash(blend, dependencies=()):
    """sha256 over the .blend and the external files it uses (images, libraries)."""
    h = hashlib.sha256(sha256_file(blend).encode())
    for dep in sorted(dependencies):
        h.update(dep.encode())
        h.update(_file_hash(dep).encode())
    return h.hexdigest()


def _file_hash(path):
    """A dependency's sha256, or what stands for one it cannot read: the image checks name a
    missing or unreadable image (and its fix) when the asset is baked."""
    if not Path(path).is_file():
        return "missing"
    try:
        return sha256_file(path)
    except OSError:                 # (permission denied): a pool thread must not die of it
        return "unreadable"


def checked_options(output, workers, worker_timeout, threads, empty_tiles, tiles, settings_file,
                    defaults):
    """bake_batch's options checked before any file is opened (BatchError names the first
    bad one, or every bad setting); returns (tiles, base settings, per-asset overrides)."""
    check_pattern(output)
    lo, hi = NO.WORKERS_RANGE
    if workers is None or isinstance(workers, bool) or not isinstance(workers, int) \
            or not lo <= workers <= hi:
        # 1e9 workers: a list of a billion process slots (8 GB) before any bake
        raise BatchError(f"workers {workers!r}: give 0 (this process) to {hi} processes")
    if worker_timeout is not None and (isinstance(worker_timeout, bool) or
                                       not isinstance(worker_timeout, (int, float)) or
                                       not 0 < worker_timeout <= NO.WORKER_TIMEOUT_MAX):
        # inf (or 1e10): past threading's longest wait, an OverflowError in a pool thread
        raise BatchError(f"worker timeout {worker_timeout!r}: give seconds, more than 0 and "
                         f"at most {NO.WORKER_TIMEOUT_MAX:.0f}")
    problem = threads is not None and BR.whole_number_problem("threads", threads,
                                                              *BR.THREADS_RANGE)
    if problem:
        raise BatchError(problem)                           # before any file opens
    if empty_tiles not in ("error", "skip"):
        raise BatchError("empty tiles: use 'error' or 'skip'")
    tiles = _tile_list(tiles)
    overrides_data = load_settings_file(settings_file) if settings_file else {}
    base = dict(overrides_data.get("defaults", {}))
    base.update({k: v for k, v in (defaults or {}).items() if v is not None})
    bad = sorted(set(base) - set(SETTING_KEYS))
    if bad:
        raise BatchError(f"unknown setting(s) {', '.join(bad)}; the settings are "
                         f"{', '.join(SETTING_KEYS)}")
    overrides = overrides_data.get("assets", {})
    problems = BR.settings_problems(base, "settings")
    for where, block in [("settings", base)] + [(f"settings for {k!r}", v)
                                                  for k, v in overrides.items()]:
        if block.get("depth") is not None and not BR.settings_problems(
                {"depth": block["depth"]}):
            try:
                NB.depth_for(str(output), block["depth"])
            except NB.NormalBakeError as err:
                problems.append(f"{where}: {err}")
    if problems:
        raise BatchError(joined(problems))
    return tiles, base, overrides


def _tile_list(value):
    """'1001-1003,1005' / [1001, 1002] / None -> sorted tiles (None stays None)."""
    try:
        return T.parse_tiles(value)
    except ValueError as err:
        raise BatchError(str(err)) from None


def split_entry(entry, folder="."):
    """'file.blend' or 'file.blend:Object' -> (file, object or None). An object's name may
    hold ".blend:" too: the file is the text up to the first ".blend:" naming an existing file
    (relative paths from `folder`), or, where none does, up to the first (refused as missing)."""
    text = str(entry)
    cuts = [m.start() + len(".blend") for m in re.finditer(r"\.blend:", text)
            if m.end() < len(text)]
    if not cuts:
        return text, None
    exists = [c for c in cuts if (Path(folder) / home_path(text[:c])).is_file()]
    cut = (exists or cuts)[0]
    return text[:cut], text[cut + 1:]


def home_path(text, listing=None):
    """`text` with a leading `~` as the home folder. Where this process has none (HOME unset
    and no password entry for its user id: a container run under an arbitrary uid), Python
    raised "Could not determine home directory.", which the batch printed alone (exit 2):
    the path as written, or, for a line of the asset list `listing`, a BatchError naming it."""
    try:
        return Path(text).expanduser()
    except RuntimeError:
        if listing is None:
            return Path(text)
        raise BatchError(f"asset list {listing}: {text!r} starts with '~', but this process "
                         f"has no home folder (HOME is not set, and the system knows none for "
                         f"this user): set HOME, or write the path in full or relative to the "
                         f"list's folder") from None


def grouped_entries(blends):
    """Entries ('file.blend' or 'file.blend:Object') by file: ({file: objects named with it},
    {files named alone (all their assets)}), files as absolute paths in the entries' order."""
    per_file, whole = {}, set()
    for entry in blends:
        blend, obj = split_entry(entry)
        # Not resolved: a symbolic link stays one, as Blender opens it ('//' paths are from
        # the link's folder; resolved, the batch read the textures beside the link's target).
        blend = os.path.abspath(blend)
        per_file.setdefault(blend, [])
        if obj:
            per_file[blend].append(obj)
        else:
            whole.add(blend)
    return per_file, whole


def read_asset_list(path):
    """An asset list: one `file.blend` or `file.blend:Object` a line (# comments); relative
    paths are taken from the list's folder, `~` is the home folder (as a shell would have it
    on the command line; an object's name is kept as written, trailing spaces too: the
    session falls back to the name without them). Returns the entries with absolute paths."""
    path = Path(path)
    if path.is_dir():
        raise BatchError(f"asset list {path} is a folder: give the list's file (one .blend "
                         f"path a line), or the .blend files themselves")
    if not path.is_file():
        raise BatchError(f"asset list {path}: no such file")
    entries = []
    text = _read_text(path, "asset list", "save it as UTF-8, one .blend path a line")
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        blend, obj = split_entry(raw.lstrip(), path.parent)   # a name may end in spaces
        p = home_path(blend.rstrip() if obj is None else blend, path)
        p = p if p.is_absolute() else path.parent / p
        entries.append(f"{p}:{obj}" if obj else str(p))
    return entries


def bake_timeout(settings, n_tiles):
    """Seconds a worker's bake may take before it is taken as hung: BAKE_TIMEOUT_S plus the
    texel-samples at TEXEL_SAMPLES_PER_S, generous (about 30x a loaded 2-core machine)."""
    texels = int(settings.get("resolution") or DEFAULTS["resolution"]) ** 2
    work = texels * int(settings.get("samples") or 1) * max(1, int(n_tiles))
    return BAKE_TIMEOUT_S + work / TEXEL_SAMPLES_PER_S



def asset_problem(scan, s, blend_name=""):
    """What stops this asset from baking, known from the scan (None if nothing): the
    bake request's checks of its mesh and images, its UV map and layout."""
    name = scan["object"]
    if scan["type"] != "MESH":
        return scan.get("not_a_mesh") or not_a_mesh(name, scan["type"], "pick mesh objects")
    if s["uv_map"] in scan.get("modifier_uvs", ()):
        return NB.modifier_uv_problem(name, s["uv_map"])
    if not scan["uv_maps"]:
        return f"object {name!r} has no UV map; unwrap it first"
    if s["uv_map"] and s["uv_map"] not in scan["uv_maps"]:
        return (f"object {name!r} has no UV map {s['uv_map']!r}; it has "
                f"{sorted(scan['uv_maps'])}")
    if not scan["materials"]:
        return f"object {name!r} has no material to bake"
    if scan.get("problems"):
        return joined(scan["problems"])
    uv = s["uv_map"] or scan["active_uv"] or next(iter(scan["uv_maps"]))
    outside = scan.get("outside", {}).get(uv, 0)
    if outside and not scan["uv_maps"].get(uv):       # --allow-partial would bake nothing
        return NB.no_tile_problem(name, uv, scan.get("uv_spans", {}).get(uv))
    if outside and not s.get("allow_partial"):
        return (f"{outside} face(s) of UV map {uv!r} of object {name!r} lie outside the UDIM "
                f"range ({T.UDIM_SPAN}) and would not be baked: move them into tiles, or "
                f"bake the rest on purpose with --allow-partial (settings file: "
                f"\"allow_partial\": true for {blend_name}:{name})")
    return None


def replaceable(prev, output, tiles):
    """Whether a bake of `output` (UDIM `tiles`, and the tiles of its pending files) may
    replace the files at its names without --overwrite: the earlier run's files are unchanged,
    and every file there now is one of them, or one a run was about to record when it was
    killed (its "pending" records: put in place, not yet recorded) still holding what that run
    wrote ("earlier_files": those of a run before one that did not finish the asset). One it does not record (the pattern, or the UV tiles, changed since) is someone
    else's: it was replaced, exit 0."""
    written = [*(prev.get("files") or {}).values(), *(prev.get("earlier_files") or {}).values()]
    hashes = {}                                   # path -> the contents recorded for it
    for r in [*written, *(prev.get("pending") or {}).values()]:
        hashes.setdefault(str(Path(r["path"]).resolve()), set()).add(r["sha256"])
    now = {p: _file_hash(Path(p)) for p in hashes}
    written = {str(Path(r["path"]).resolve()) for r in written}
    if any(now[p] not in hashes[p] for p in written):     # edited or removed since
        return False
    ours = {p for p in hashes if now[p] in hashes[p]}
    finals = {T.tile_path(Path(output).resolve(), t) for t in tiles} | \
        {Path(r["path"]).resolve() for r in (prev.get("pending") or {}).values()}
    return bool(ours) and all(str(f) in ours or not f.exists() for f in finals)


def same_bake_files(prev, entry):
    """The files an earlier run recorded for this asset that this bake keeps: those of the
    same inputs and settings (other tiles: --tiles), still holding what was written."""
    if prev.get("input_hash") != entry["input_hash"] or \
            prev.get("settings_hash") != entry["settings_hash"]:
        return {}
    return {t: r for t, r in (prev.get("files") or {}).items()
            if _file_hash(Path(r["path"])) == r["sha256"]}


def unchanged_outputs(prev):
    """True if every file an earlier run recorded still holds what it wrote."""
    files = prev.get("files") or {}
    if not files:
        return False
    for rec in files.values():
        p = Path(rec["path"])
        if _file_hash(p) != rec["sha256"]:
            return False
    return True
