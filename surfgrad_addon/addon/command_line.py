"""A command line from a table of subcommands: both `python -m surfgrad_addon` (the harness's
table, harness/cli.py) and `blender -c surfgrad` (the extension's own, commands.py) are built
here, so they parse, report errors and exit the same way.

Bad input prints one line, `surfgrad: error: ...`, naming the thing and the fix, and gives the
exit code of exit_codes.py (2 refused before anything ran, 1 a bake failed); no traceback."""

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .exit_codes import BAD_REQUEST, BAKE_FAILED, OK, code_for
from .std_streams import prepare as prepare_streams


@dataclass(frozen=True)
class Subcommand:
    """One subcommand: its name and help, what adds its options to its parser, and what runs
    it with the parsed options (returns the exit code; None means 0). Unless it stops itself
    (installs its own Ctrl-C / SIGTERM handling), it runs inside interrupts.stoppable. One
    that loads Blender is refused under an address-space limit too low to load it."""
    name: str
    help: str
    arguments: Callable
    run: Callable
    stops_itself: bool = False
    loads_blender: bool = True


def parser(subcommands, prog, description, raw_description=False):
    p = argparse.ArgumentParser(prog=prog, description=description, formatter_class=(
        argparse.RawDescriptionHelpFormatter if raw_description else argparse.HelpFormatter))
    sub = p.add_subparsers(dest="command", required=True)
    for command in subcommands:
        command.arguments(sub.add_parser(command.name, help=command.help))
    return p


def run(subcommands, args):
    """Run the parsed command: its exit code, errors reported as one line."""
    command = next(c for c in subcommands if c.name == args.command)
    prepare_streams()            # `blender -c surfgrad ... >&-`; non-UTF-8 paths
    problems = [working_folder_problem()] + \
        [_name_problem(n, getattr(args, n, None)) for n in NAME_OPTIONS] + \
        [_home_paths(args, n) for n in PATH_OPTIONS]
    problems = [p for p in problems if p]
    if problems:
        print(f"surfgrad: error: {'; '.join(problems)}", file=sys.stderr)
        return BAD_REQUEST
    if command.loads_blender and "bpy" not in sys.modules:
        # `ulimit -v` too low: importing bpy would crash or hang with no line (memory_limit.py)
        from .memory_limit import start_problem
        problem = start_problem()
        if problem:
            print(f"surfgrad: error: {problem}", file=sys.stderr)
            return BAD_REQUEST
    if command.stops_itself:
        return _run(command, args)
    from . import interrupts
    # Ctrl-C / SIGTERM stop the command at once, exit 130 / 143, nothing written.
    try:
        with interrupts.stoppable(command.name, load_blender=command.loads_blender):
            return _run(command, args)
    except ImportError as err:      # (bpy's import, in the block's start)
        return _unloadable(command.name, err)


def _no_bpy_problem(name):
    """Why this Python cannot run command `name`, which loads Blender: no bpy module.
    `python -m surfgrad_addon bake-normal-map` on a Python without the bpy wheel ended in a raw
    ModuleNotFoundError traceback, exit 1 (rt57a). Told where bpy's import fails (_unloadable),
    not before the command: a request that is wrong anyway (an empty asset list) is told so
    first, without Blender."""
    version = ".".join(map(str, sys.version_info[:2]))
    return (f"{name} needs Blender's Python module bpy, which this Python ({version}, "
            f"{sys.executable}) does not have: install the bpy wheel of your Blender line into "
            f"it (pip install bpy==5.2.3, on Python 3.13; docs/versions.md names the others), "
            f"or bake inside Blender (blender -c surfgrad bake-normal-map ...)")


def _unloadable(name, err):
    """Exit code and line for an ImportError out of command `name`: bpy is there (find_spec
    found it) but would not load, e.g. a system library its wheel links missing on a bare farm
    node or container ("libXi.so.6: cannot open shared object file"). Before: a raw
    ImportError traceback, exit 1, from bake-normal-map, bake-batch, compare and compare-all
    alike (rt58a). Another module's ImportError, with bpy loaded, goes on up as it was."""
    if "bpy" in sys.modules:
        raise err
    if isinstance(err, ModuleNotFoundError) and err.name == "bpy":
        print(f"surfgrad: error: {_no_bpy_problem(name)}", file=sys.stderr)
        return BAD_REQUEST
    version = ".".join(map(str, sys.version_info[:2]))
    inside = (f", or bake inside Blender (blender -c surfgrad {name} ...)"
              if name.startswith("bake-") else "")
    print(f"surfgrad: error: {name} could not load Blender's Python module bpy on this Python "
          f"({version}, {sys.executable}): {err}: install what it names (a system library "
          f"Blender needs: your distribution's package that holds that file), or reinstall "
          f"the bpy wheel of your Blender line for this Python (docs/versions.md){inside}",
          file=sys.stderr)
    return BAD_REQUEST


def working_folder_problem():
    """The folder the command was started in removed since (a farm's task folder cleaned up,
    a shell left in a deleted folder): a relative path then names nothing, and resolving one
    ended in a raw FileNotFoundError traceback."""
    try:
        os.getcwd()
    except FileNotFoundError:
        return ("the current folder no longer exists (removed after this shell or task "
                "entered it): cd to a folder that exists and run the command again")
    return None


# Options that name things in the .blend (not paths, which may be any bytes).
NAME_OPTIONS = ("object", "objects", "collections", "uv_map")

# Options that are paths (or lists of them): a leading '~' is the home folder.
PATH_OPTIONS = ("blend", "blends", "output", "manifest", "settings", "asset_list", "json",
                "image", "out")


def _home_paths(args, name):
    """Expand a leading '~' in the path option `name` of args in place (None, or the
    problem). A quoted path keeps it from the shell (patterns are quoted for their '<UDIM>'):
    `--output "~/maps/{object}.<UDIM>.png"` made a folder named '~' in the current folder and
    baked there, exit 0 (the asset list took '~' as the home folder already)."""
    value = getattr(args, name, None)
    values = value if isinstance(value, list) else [value]
    out = []
    for v in values:
        if isinstance(v, str) and v.startswith("~"):
            try:
                v = str(Path(v).expanduser())
            except RuntimeError:
                return (f"{_option(name)} {v!r} starts with '~', but this process has no "
                        f"home folder (HOME is not set, and the system knows none for this "
                        f"user): set HOME, or write the path in full")
        out.append(v)
    setattr(args, name, out if isinstance(value, list) else out[0])
    return None


def _option(name):
    return "a .blend" if name == "blends" else "--" + name.replace("_", "-")


def _name_problem(option, value):
    """The problem of the first name of an option that is not UTF-8 (utf8_names.py)."""
    from .utf8_names import problem
    for name in [value] if isinstance(value, str) else value or ():
        found = problem(f"--{option.replace('_', '-')}", name)
        if found:
            return found
    return None


def leave(code):
    """code, with every object still alive frozen (gc.freeze) for a process about to exit:
    the interpreter's last garbage collections then skip them. They walked every object of
    numba's type system and loaded kernels: 0.2 s of a 2048^2 compare's exit, 0.1 s of a
    bake's. Nothing of ours needs them: a command has written and closed its files before it
    returns, and weakref.finalize hooks (temporary folders) still run at exit. Call it only
    where the process ends next (never in a test's process, which goes on; in a Blender
    script only where blender_exits_next). The stop signals are ignored from here on
    (interrupts.ignore_at_exit)."""
    import gc
    from . import interrupts
    interrupts.ignore_at_exit()
    gc.freeze()
    return code


# Blender's arguments that may end its list after a script: the exit code's, then the script's.
EXIT_CODE_ARG, SCRIPT_ARGS = "--python-exit-code", ("-P", "--python")


def blender_exits_next(argv, background, script):
    """Whether Blender exits once the script `script` (blender_cli.py, bake_normal_map.py)
    returns 0: under -b (`background`), the last of Blender's arguments (but
    --python-exit-code N) before `--`. Elsewhere it goes on, with its UI or with the
    arguments after the script (a render, another script), and must stay stoppable: leave()
    would have ignored SIGTERM and Ctrl-C there for good (red team 59g)."""
    if not background:
        return False
    head = list(argv[:argv.index("--")] if "--" in argv else argv)
    while len(head) >= 2 and head[-2] == EXIT_CODE_ARG:
        head = head[:-2]
    return len(head) >= 2 and head[-2] in SCRIPT_ARGS \
        and Path(head[-1]).resolve() == Path(script).resolve()


def end_script(code, script):
    """The end of a Blender script (blender_cli.py, bake_normal_map.py) whose command returned
    `code`: a failure exits Blender with it; success leaves Blender to go on (its UI, the
    arguments after the script), with leave() only where it exits next (blender_exits_next)."""
    if code:
        sys.exit(leave(code))
    import bpy                                  # Blender's, as the script runs in it
    if blender_exits_next(sys.argv, bpy.app.background, script):
        leave(code)


def _run(command, args):
    try:
        code = command.run(args)
    except ImportError as err:      # bpy's import, where the command holds the signals itself
        return _unloadable(command.name, err)
    except (FileExistsError, ValueError, KeyError, RuntimeError) as err:
        print(f"surfgrad: error: {err}", file=sys.stderr)
        return code_for(err)
    except MemoryError:
        # numpy's, or Python's: an address-space limit (`ulimit -v`, SGE's h_vmem) or the
        # machine's memory ran out mid-command. Staged outputs are removed on the way out.
        print("surfgrad: error: ran out of memory (an address-space limit such as `ulimit -v` "
              "or the job's h_vmem, or the machine's memory): raise the limit, or ask for less "
              "(a lower --resolution, smaller images)", file=sys.stderr)
        return BAKE_FAILED
    return OK if code is None else code
