"""Build and validate the extension zip with Blender's own extension builder.

    python -m surfgrad_addon.harness.package --out DIR [--overwrite]   # prints the zip's path

No `blender` binary is needed: the bpy wheel ships the `bl_pkg` add-on, whose
`bl_extension_cli.cli_extension_handler(args)` is what `blender --command extension ARGS` runs.
The extension's root is the `surfgrad_addon` package itself (its `__init__.py` has
register/unregister). The build stages `blender_manifest.toml` and the parts of the package
that make the extension (SHIPPED: `__init__.py`, `api.py`, `addon/`, `reference/`) in a
temporary folder (without `__pycache__`) and builds from there. The proving harness (`harness/`, the
`python -m` entry and the checkout scripts), tests, venvs and out/ never reach the zip.
"""

import argparse
import contextlib
import io
import os
import shutil
import sys
import tempfile
import tomllib
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1]         # surfgrad_addon/
ROOT = PACKAGE_DIR.parent                                 # the repository
MANIFEST = ROOT / "blender_manifest.toml"
IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.pyo")
# What the extension is made of: the add-on and the numpy reference it reads its facts from.
SHIPPED = ("__init__.py", "api.py", "addon", "reference")


class ExtensionToolError(RuntimeError):
    """Blender's extension command failed; the message carries its output."""


def manifest():
    with open(MANIFEST, "rb") as fh:
        return tomllib.load(fh)


def zip_name():
    m = manifest()
    return f"{m['id']}-{m['version']}.zip"


def stage(dest):
    """Copy the manifest and the SHIPPED parts of the package into `dest`."""
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    for name in SHIPPED:
        src = PACKAGE_DIR / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=IGNORE, dirs_exist_ok=True)
        else:
            shutil.copy2(src, dest / name)
    shutil.copy2(MANIFEST, dest / "blender_manifest.toml")
    return dest


def expected_files():
    """The zip's file list: the manifest and every SHIPPED file, paths relative to the root."""
    files = {"blender_manifest.toml"}
    for name in SHIPPED:
        src = PACKAGE_DIR / name
        if src.is_file():
            files.add(name)
            continue
        for dirpath, dirnames, filenames in os.walk(src):
            dirnames[:] = [d for d in dirnames if d != "__pycache__"]
            rel = Path(dirpath).relative_to(PACKAGE_DIR)
            files.update((rel / f).as_posix() for f in filenames
                         if not f.endswith((".pyc", ".pyo")))
    return files


def extension_cli():
    """Blender's `cli_extension_handler` from the wheel's bl_pkg add-on (imports bpy)."""
    import bpy
    try:
        from bl_pkg import bl_extension_cli
    except ImportError:            # addons_core not on sys.path: add it from the install
        sys.path.append(bpy.utils.system_resource('SCRIPTS', path="addons_core"))
        from bl_pkg import bl_extension_cli
    return bl_extension_cli.cli_extension_handler


def run_extension_command(args):
    """`blender --command extension ARGS`; returns its output, raises ExtensionToolError."""
    handler = extension_cli()
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        try:
            rc = handler(list(args))
        except SystemExit as ex:     # argparse errors
            rc = ex.code if isinstance(ex.code, int) else 1
    text = out.getvalue()
    if rc != 0:
        raise ExtensionToolError(f"extension {' '.join(args)} failed ({rc}):\n{text}")
    return text


def validate(path):
    """Blender's validator on a source folder or a built zip; returns its output."""
    return run_extension_command(["validate", str(path)])


class ZipExists(ExtensionToolError):
    """The zip is there already and replacing it was not asked for."""


def build(out_dir, log=None, overwrite=False):
    """Stage, validate, build and validate the zip; returns the zip's path in `out_dir`. An
    existing zip of that name is replaced only with `overwrite`, and only once the new one is
    built and validated (it is built beside it under another name): a failed build leaves it."""
    out_dir = Path(out_dir).resolve()
    target = out_dir / zip_name()
    if target.exists() and not overwrite:
        raise ZipExists(f"{target} exists: pass --overwrite to replace it, or give another "
                        f"--out folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="surfgrad-stage-") as tmp:
        source = stage(Path(tmp) / "surfgrad")
        built = Path(tempfile.mkdtemp(prefix=".surfgrad-zip-", dir=out_dir)) / target.name
        try:
            messages = [validate(source),
                        run_extension_command(["build", "--source-dir", str(source),
                                               "--output-filepath", str(built)]),
                        validate(built)]
            os.replace(built, target)
        finally:
            shutil.rmtree(built.parent, ignore_errors=True)
    if log is not None:
        log.write("".join(messages))
    return target


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m surfgrad_addon.harness.package",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="folder for the zip")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace a zip of the same name in that folder (else refused)")
    args = parser.parse_args(argv)
    try:
        path = build(args.out, log=sys.stderr, overwrite=args.overwrite)
    except ZipExists as ex:
        print(f"surfgrad: {ex}", file=sys.stderr)
        return 2
    except ExtensionToolError as ex:
        print(ex, file=sys.stderr)
        return 1
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
