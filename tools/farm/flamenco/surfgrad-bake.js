// SPDX-License-Identifier: GPL-3.0-or-later
// Flamenco 3 job type: surfgrad normal-map bakes, one task per object x UDIM tile.
// Install: put this file in the `scripts` folder next to the flamenco-manager executable and
// restart the Manager; workers need Blender 4.2+ with the surfgrad extension enabled (their
// Blender runs `--python-exit-code 1 --python-expr`, which calls the extension's `bake-batch`
// command on the file Flamenco opened; any Python error fails the task). Written for the
// Manager's runtime: strict mode, and settings exactly as submitted (the Manager fills in no
// defaults: compileJob does). See README.md, "Bake on a farm".

const JOB_TYPE = {
  label: "surfgrad Normal-Map Bake",
  description: "Bake materials into normal maps, one task per object and UDIM tile",
  settings: [
    { key: "objects", type: "string", required: true,
      // A comma or backslash inside a name is escaped with a backslash (parseObjects).
      eval: "','.join(o.name.replace('\\\\', '\\\\\\\\').replace(',', '\\\\,') " +
            "for o in C.selected_objects if o.type == 'MESH')",
      evalInfo: { showLinkButton: true, description: "The selected mesh objects" },
      description: "Mesh objects to bake, separated by commas; write a comma or backslash " +
                   "inside a name as \\, or \\\\" },
    { key: "tiles", type: "string", default: "1001",
      description: "UDIM tiles, e.g. '1001-1004' or '1001,1003'; tiles an object has no UVs " +
                   "in are skipped" },
    { key: "output_pattern", type: "string", subtype: "file_path", required: true,
      default: "//maps/{file}_{object}.<UDIM>.png",
      description: "Output files: {file}, {object}, {uv}, <UDIM>; '//' is the blend file's folder" },
    { key: "manifest_dir", type: "string", subtype: "dir_path", default: "//maps/manifests",
      description: "Folder for the per-task manifests (JSON)" },
    // The add-on evaluates hidden settings in the artist's Blender on submission: '//' there is
    // the project's folder. On the farm the file is a copy (with Shaman, deleted with the job),
    // so the tasks write only to these absolute paths.
    { key: "output_path", type: "string", visible: "hidden",
      eval: "str(abspath(settings.output_pattern))",
      description: "output_pattern as an absolute path, resolved on submission" },
    { key: "manifest_path", type: "string", visible: "hidden",
      eval: "str(abspath(settings.manifest_dir))",
      description: "manifest_dir as an absolute path, resolved on submission" },
    { key: "resolution", type: "int32", default: 2048, description: "Texels per side" },
    { key: "samples", type: "int32", default: 16, description: "Cycles samples per texel" },
    { key: "margin", type: "int32", default: 16, description: "Texels past UV borders" },
    { key: "space", type: "string", choices: ["tangent", "object"], default: "tangent" },
    { key: "depth", type: "string", choices: ["auto", "8", "16", "half", "float"],
      default: "auto", description: "8/16-bit PNG, half/float EXR (auto: 8-bit PNG, float EXR)" },
    { key: "blendfile", type: "string", required: true, visible: "web",
      description: "The blend file to bake" },
  ],
};

// Runs the installed extension's command handler (`blender -c surfgrad ...` without -c, which
// would not load the file) on the arguments after `--`, and exits with its code. Without the
// extension: exit 2 (refused, nothing baked, as docs/pipelines.md's codes say), the line on
// stderr with the fix (it was exit 3 on stdout).
const PYTHON_EXPR =
  "import sys; " +
  "m = next((v for k, v in list(sys.modules.items()) " +
  "if k.endswith('.addon.commands') and hasattr(v, 'run_bake_batch')), None); " +
  "sys.exit(m.execute(sys.argv[sys.argv.index('--') + 1:]) if m else " +
  "(print('surfgrad: error: the surfgrad extension is not enabled in this worker\\'s " +
  "Blender: install it and enable it in Preferences > Get Extensions (Blender 4.2 or later), " +
  "then requeue the task', file=sys.stderr) or 2))";

function parseTiles(text) {
  const tiles = [];
  for (const part of String(text).split(",")) {
    const item = part.trim();
    if (!item) continue;
    const range = item.split("-");
    const lo = parseInt(range[0], 10);
    const hi = range.length > 1 ? parseInt(range[1], 10) : lo;
    if (!Number.isInteger(lo) || !Number.isInteger(hi) || lo < 1001 || hi > 2000 || hi < lo) {
      throw `tiles '${text}': give UDIM numbers from 1001 to 2000, like 1001-1004 or 1001,1003`;
    }
    for (let t = lo; t <= hi; t++) if (!tiles.includes(t)) tiles.push(t);
  }
  if (!tiles.length) throw "tiles: give at least one UDIM tile, like 1001";
  return tiles.sort((a, b) => a - b);
}

// Object names from the comma-separated list; a backslash escapes the next character, so a
// name holding a comma ("Rock, big" as "Rock\, big") stays one name. Repeats are dropped.
function parseObjects(text) {
  const names = [];
  let name = "";
  const finish = () => {
    const n = name.trim();
    if (n && !names.includes(n)) names.push(n);
    name = "";
  };
  const chars = Array.from(String(text));
  for (let i = 0; i < chars.length; i++) {
    if (chars[i] === "\\" && i + 1 < chars.length) name += chars[++i];
    else if (chars[i] === ",") finish();
    else name += chars[i];
  }
  finish();
  return names;
}

// The per-task manifest file names: an object name may hold '/', '\', ':' or be '..', which
// in a path would leave the manifest folder; those characters and leading dots become '_', and
// names that then meet (also when they differ only in case: macOS and Windows folders ignore
// case) get a number, so no two tasks write one manifest.
function manifestNames(objects, tiles) {
  const used = new Set();
  const names = new Map();
  for (const name of objects) {
    let safe = name.replace(/[\/\\:*?"<>|\x00-\x1f]/g, "_");
    safe = safe.replace(/^\.+/, (dots) => "_".repeat(dots.length));   // not hidden, not '..'
    let base = safe;
    const key = (t) => foldName(`${base}-${t}`);
    for (let k = 2; tiles.some((t) => used.has(key(t))); k++) {
      base = `${safe}_${k}`;
    }
    for (const t of tiles) used.add(key(t));
    names.set(name, base);
  }
  return names;
}

// A name as a file system that ignores case and Unicode's normal forms may take it: one normal
// form, then full case folding, as bake-batch folds names (Python's casefold) and as Linux's
// case-insensitive folders (ext4, f2fs) and APFS do: 'Straße' and 'STRASSE', 'ﬁx' and 'FIX' are
// one name there, where toLowerCase alone keeps them apart. JavaScript has no casefold; lower,
// upper, lower again folds the same pairs (checked against Python's casefold over all of
// Unicode), and one more: the dotless 'ı' meets 'i' (one file on NTFS too, whose table
// upper-cases 'ı' to 'I'), so a pair is refused rather than let through.
function foldName(name) {
  return name.normalize("NFC").toLowerCase().toUpperCase().toLowerCase();
}

// An object's name as bake-batch puts it in a file name (plan._safe: folder separators and
// characters Windows refuses become '_', spaces at the ends go, a name of only dots becomes
// '_'s).
function safeName(name) {
  const safe = name.replace(/[\\\/:*?"<>|\x00-\x1f]/g, "_").trim() || "_";
  return /^\.+$/.test(safe) ? "_".repeat(safe.length) : safe;
}

// Each object is its own task, so bake-batch's check of two assets on one file never meets
// two of them: an output pattern without {object} (or two names that become one, 'Wall:L' and
// 'Wall_L') had the first task bake and the second fail as "... exists; pass --overwrite", an
// option this job does not have. Refused on submission where the file is certain (no {uv}:
// objects' UV maps are known only on the farm).
// Names that differ only in case ('Rock', 'rock') or in Unicode's normal form (an 'é' as one
// character, or as 'e' and a combining accent) are one file where the maps land on a macOS or
// Windows disk or share; the farm's storage cannot be probed from here, so they are refused
// too (before: two tasks, the second failing with "exists").
function checkOutputsApart(objects, output) {
  if (output.includes("{uv}")) return;
  const seen = new Map();
  for (const name of objects) {
    const safe = output.includes("{object}") ? safeName(name) : "";
    const key = foldName(safe);
    if (seen.has(key)) {
      const [other, otherSafe] = seen.get(key);
      const why = !output.includes("{object}") ? "" : otherSafe === safe ?
        ` (both become '${safe}' in a file name)` :
        ` ('${otherSafe}' and '${safe}' in file names, one file on a disk or share that ` +
        "ignores case or Unicode's normal forms: macOS, Windows, most SMB shares)";
      throw `output_pattern '${output}' names one file for objects '${other}' and '${name}'` +
        why + ": each object is its own task, so the second task would fail; " +
        (output.includes("{object}") ? "rename one of them" : "put {object} in the pattern");
    }
    seen.set(key, [name, safe]);
  }
}

// A setting as submitted, else the job type's default (the Manager applies none).
function setting(s, key) {
  const value = s[key];
  if (value !== undefined && value !== null) return value;
  const spec = JOB_TYPE.settings.find((x) => x.key === key);
  if (spec && "default" in spec) return spec.default;
  throw `${key}: this job needs it; submit the job from Blender's Flamenco add-on, or set it`;
}

function isAbsolute(p) {
  return p.startsWith("/") && !p.startsWith("//") || /^[A-Za-z]:[\\/]/.test(p) ||
    p.startsWith("\\\\");
}

// An output as an absolute path: the value the add-on resolved on submission, else the
// setting itself if absolute. A blend-relative ('//') or relative path would resolve inside
// the farm's copy of the file (deleted with the job): refused with the fix.
function absoluteOutput(s, key, resolvedKey) {
  const resolved = s[resolvedKey];
  const p = String(resolved !== undefined && resolved !== null && resolved !== "" ? resolved :
    setting(s, key));
  if (!isAbsolute(p)) {
    throw `${key} '${p}' is relative: on the farm it would resolve inside the job's copy of ` +
      "the blend file (with Shaman, deleted with the job), so the files would vanish and a " +
      "resubmitted job would never skip unchanged work; submit from Blender's Flamenco " +
      "add-on (it resolves '//' against your file) or give an absolute path";
  }
  return p;
}

function compileJob(job) {
  const s = job.settings;
  const objects = parseObjects(setting(s, "objects"));
  if (!objects.length) throw "objects: name at least one mesh object to bake";
  const blendfile = String(setting(s, "blendfile"));
  if (!blendfile) throw "blendfile: the job needs the blend file to bake";
  const tiles = parseTiles(setting(s, "tiles"));
  const output = absoluteOutput(s, "output_pattern", "output_path");
  const manifests = absoluteOutput(s, "manifest_dir", "manifest_path").replace(/[\\/]+$/, "");
  checkOutputsApart(objects, output);
  const manifestName = manifestNames(objects, tiles);
  for (const name of objects) {
    for (const tile of tiles) {
      const task = author.Task(`bake ${name} ${tile}`, "blender");
      task.addCommand(author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        // Before the file: Blender opens it with its scripts off, whatever the farm
        // worker's Preferences say (a .blend's drivers and text blocks never run).
        argsBefore: ["--disable-autoexec"],
        blendfile: blendfile,
        args: [
          // --python-exit-code 1 before --python-expr: a Python error exits 1, not 0 (failed).
          "--python-exit-code", "1", "--python-expr", PYTHON_EXPR, "--",
          "bake-batch", "--open-file", `--objects=${name}`,
          "--tiles", String(tile), "--if-tile-empty", "skip",
          "--output", output,
          "--manifest", `${manifests}/${manifestName.get(name)}-${tile}.json`,
          "--resolution", String(setting(s, "resolution")),
          "--samples", String(setting(s, "samples")),
          "--margin", String(setting(s, "margin")), "--space", String(setting(s, "space")),
          "--depth", String(setting(s, "depth")), "--workers", "0",
        ],
      }));
      job.addTask(task);
    }
  }
}
