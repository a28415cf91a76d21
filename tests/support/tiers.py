"""The suite's tiers: each test is in exactly one, so `pytest -m numpy` (or bake, ...) picks a
tier, and the suite's time is recorded per tier.

A test file declares its tier once, `pytestmark = pytest.mark.tier("bake")`, and a test that
differs carries its own `@pytest.mark.tier("numpy")` (the closest declaration wins);
tests/conftest.py turns the declaration into the tier's marker. A tier is the heaviest thing a
test does (its fixtures included):

    numpy    needs no bpy
    blender  needs bpy in this process, bakes and renders nothing
    bake     runs Cycles in this process (a bake or a render)
    child    starts another process (a child interpreter, batch workers, a farm CLI)
    eevee    renders with EEVEE (in a child that makes its GPU context)

The declaration cannot silently fall behind what a test does: while a test runs (set-up and
call) the guard below watches for bpy imports, Cycles bakes and renders, and new processes,
and a test that does more than its tier allows fails, naming the tier it needs. (A test that
does less than its tier stays where it is: it costs time, it hides nothing.)
"""

import json
import os
import sys
import sysconfig
import time
import traceback
from pathlib import Path

import pytest

TIERS = ("numpy", "blender", "bake", "child", "eevee")
DESCRIPTIONS = {
    "numpy": "needs no bpy",
    "blender": "needs bpy in this process; bakes and renders nothing",
    "bake": "runs Cycles in this process (a bake or a render)",
    "child": "starts another process (a child interpreter, batch workers, a farm CLI)",
    "eevee": "renders with EEVEE (in a child process)",
}
# What a tier may do, each a step up from the one before.
_ALLOWED = {"numpy": set(), "blender": {"bpy"}, "bake": {"bpy", "cycles"},
            "child": {"bpy", "cycles", "process"},
            "eevee": {"bpy", "cycles", "process", "eevee"}}
# The lowest tier that allows an action.
NEEDS = {"bpy": "blender", "cycles": "bake", "process": "child", "eevee": "eevee"}

_BLENDER_TOP = ("bpy", "_bpy", "mathutils", "bmesh", "bpy_extras", "bpy_types", "gpu",
                "gpu_extras")
_PROCESS_EVENTS = {"subprocess.Popen", "os.posix_spawn", "os.fork", "os.forkpty", "os.system",
                   "os.exec", "os.spawn"}
# Where the standard library lives: a process started from it is someone else's call.
_STDLIB = sysconfig.get_paths()["stdlib"]


def _library_lookup(stack):
    """Whether the innermost caller outside the standard library is an installed package:
    a library running a helper program to look something up (numpy 1.26 runs lscpu when
    numpy.testing loads, matplotlib fc-list, numba its CPU probe), not a test's own process."""
    for frame in reversed(stack):
        path = frame.filename
        if "site-packages" in path or "dist-packages" in path:
            return True
        if not (path.startswith("<") or path.startswith(_STDLIB)):
            return False
    return False


class _State:
    tier = None            # the running test's tier while it is watched, else None
    seen = []              # (action, detail) the running test did beyond its tier
    hidden = {}            # Blender modules taken out of sys.modules for a numpy test


def tier_of(item):
    """The tier declared for a collected test (the closest pytest.mark.tier), or None."""
    mark = item.get_closest_marker("tier")
    return mark.args[0] if mark and mark.args else None


def _note(action, detail):
    if _State.tier is not None and action not in _ALLOWED[_State.tier]:
        _State.seen.append((action, detail))


class _BlockBlender:
    """Refuses Blender's modules while a numpy-tier test runs (their cached copies are
    hidden, so any `import bpy` reaches this finder)."""

    def find_spec(self, name, path=None, target=None):
        if _State.tier == "numpy" and name.split(".")[0] in _BLENDER_TOP:
            where = "".join(traceback.format_stack(limit=6)[:-1])
            _note("bpy", f"imports {name}:\n{where}")
            raise ImportError(f"{name} is refused in a numpy-tier test (tests/support/tiers.py)")
        return None


def _audit(event, args):
    if _State.tier is None or event not in _PROCESS_EVENTS:
        return
    stack = traceback.extract_stack()[:-1]
    if _library_lookup(stack):
        return
    what = args[1] if event == "subprocess.Popen" and len(args) > 1 else args[:1]
    where = "".join(traceback.format_list(stack[-8:-1]))
    _note("process", f"{event} {what!r}:\n{where}")


def _trace_operators():
    """Wrap bpy.ops so that object.bake and render.render report themselves (the bake
    handlers fire only for bakes started as jobs, not for the operator a script calls)."""
    ops = sys.modules["bpy"].ops
    original = ops.__dict__.get("__getattr__")
    if original is None or getattr(original, "_surfgrad_traced", False):
        return

    def submodule(module):
        sub = original(module)
        for op_module, op_name in (("object", "bake"), ("render", "render")):
            if module == op_module:
                setattr(sub, op_name, _reporting(getattr(sub, op_name), op_name))
        return sub

    submodule._surfgrad_traced = True
    ops.__getattr__ = submodule


def _reporting(operator, name):
    def call(*args, **kw):
        import bpy
        engine = bpy.context.scene.render.engine if bpy.context.scene else "?"
        if engine == "CYCLES" or name == "bake":
            _note("cycles", f"bpy.ops.{'object' if name == 'bake' else 'render'}.{name} "
                            f"({engine})")
        elif engine.startswith("BLENDER_EEVEE"):
            _note("eevee", f"bpy.ops.render.render ({engine})")
        return operator(*args, **kw)
    return call


_installed = False


def install():
    """Put the finder and the audit hook in place (once per process)."""
    global _installed
    if not _installed:
        sys.meta_path.insert(0, _BlockBlender())
        sys.addaudithook(_audit)
        _installed = True


def start(tier):
    """Watch the test about to run (set-up or call phase) at `tier`."""
    _State.tier, _State.seen = tier, []
    if "bpy" in sys.modules:
        _trace_operators()
    if tier == "numpy":
        _State.hidden = {name: mod for name, mod in sys.modules.items()
                         if name.split(".")[0] in _BLENDER_TOP}
        for name in _State.hidden:
            del sys.modules[name]


def stop():
    """End the watch; returns what the test did beyond its tier."""
    seen, tier = _State.seen, _State.tier
    _State.tier, _State.seen = None, []
    for name, mod in _State.hidden.items():
        sys.modules.setdefault(name, mod)
    _State.hidden = {}
    if seen and "bpy" in sys.modules:
        _trace_operators()
    return tier, seen


def complaint(nodeid, tier, seen):
    """The failure message for a test that did more than its tier allows."""
    need = max((NEEDS[action] for action, _ in seen), key=TIERS.index)
    lines = [f"{nodeid} is declared tier {tier!r} ({DESCRIPTIONS[tier]}) but it did more; "
             f"declare @pytest.mark.tier({need!r}) ({DESCRIPTIONS[need]}):"]
    lines += [f"  {action}: {detail}" for action, detail in seen[:5]]
    return "\n".join(lines)


# pytest hooks (tests/conftest.py imports them; `-p support.tiers` loads them elsewhere) ---------

_TIER_OF = {}            # nodeid -> tier, for the reports
_TIMES = {}              # tier -> {"tests", "seconds", "passed", "failed", "skipped"}
_START = [None]


def pytest_configure(config):
    install()
    _START[0] = time.perf_counter()


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session, config, items):
    """Turn each test's declared tier into its one tier marker, before `-m` selects; refuse a
    test without a declaration, with an unknown one, or with a tier marker set by hand."""
    problems = []
    for item in items:
        by_hand = sorted({m.name for m in item.iter_markers() if m.name in TIERS})
        tier = tier_of(item)
        if by_hand:
            problems.append(f"{item.nodeid}: marked {', '.join(by_hand)} by hand; declare "
                            f"pytest.mark.tier(...) instead")
        elif tier not in TIERS:
            problems.append(f"{item.nodeid}: " + ("no tier declared" if tier is None else
                                                  f"unknown tier {tier!r}"))
        else:
            item.add_marker(getattr(pytest.mark, tier))
            _TIER_OF[item.nodeid] = tier
    if problems:
        raise pytest.UsageError(
            "every test declares one tier (pytestmark = pytest.mark.tier(NAME) in its file, "
            "@pytest.mark.tier(NAME) on a test that differs; NAME one of "
            f"{', '.join(TIERS)}: tests/support/tiers.py):\n  " + "\n  ".join(problems[:30])
            + (f"\n  ... {len(problems) - 30} more" if len(problems) > 30 else ""))


def pytest_collection_finish(session):
    # Tests that may bake: have bpy's operators traced before the first of them runs.
    if any(_TIER_OF.get(i.nodeid) != "numpy" for i in session.items):
        try:
            import bpy  # noqa: F401
        except ImportError:
            return
        _trace_operators()


def _watch(item):
    start(tier_of(item))
    try:
        result = yield
    except BaseException as err:
        tier, seen = stop()
        if seen and not isinstance(err, KeyboardInterrupt):
            pytest.fail(complaint(item.nodeid, tier, seen), pytrace=False)
        raise
    tier, seen = stop()
    if seen:
        pytest.fail(complaint(item.nodeid, tier, seen), pytrace=False)
    return result


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    return (yield from _watch(item))


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    return (yield from _watch(item))


def pytest_runtest_logreport(report):
    tier = _TIER_OF.get(report.nodeid)
    if tier is None:
        return
    t = _TIMES.setdefault(tier, {"tests": 0, "seconds": 0.0, "passed": 0, "failed": 0,
                                 "skipped": 0})
    t["seconds"] += report.duration                 # set-up, call and teardown
    if report.when == "setup":
        t["tests"] += 1
        if report.outcome != "passed":              # a set-up error or a skip
            t[report.outcome] += 1
    elif report.when == "call":
        t[report.outcome] += 1
    elif report.failed:                             # an error in teardown
        t["failed"] += 1


def _line():
    """The running Blender's line and version, or None without bpy."""
    try:
        import bpy
    except ImportError:
        return None, None
    from surfgrad_addon.reference.blender_lines import facts_for
    return facts_for(bpy.app.version).line, bpy.app.version_string


def pytest_sessionfinish(session, exitstatus):
    """With SURFGRAD_REPORT_DIR set: durations-<line>.json, seconds and tests per tier."""
    folder = os.environ.get("SURFGRAD_REPORT_DIR")
    if not folder or not _TIMES:
        return
    line, version = _line()
    data = {"line": line, "blender": version, "python": sys.version.split()[0],
            "markexpr": session.config.getoption("markexpr", "") or "",
            "args": [str(a) for a in session.config.args],
            "wall_seconds": round(time.perf_counter() - _START[0], 1),
            "tiers": {t: {**v, "seconds": round(v["seconds"], 3)}
                      for t in TIERS if (v := _TIMES.get(t))}}
    path = Path(folder) / f"durations-{line or 'no-bpy'}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1))
