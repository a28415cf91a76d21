"""`python -m surfgrad_addon ...`: the proving harness's command line (harness/cli.py), from a
checkout. Not part of the extension zip."""

import os
import sys

# numpy asks the kernel for transparent huge pages for its large arrays (madvise). Where the
# kernel compacts memory to find them (THP defrag "madvise", as on the development machine),
# each large array allocated after a bake stalled: compare's first 32 MB took 0.07 s instead
# of 0.015 s, about 0.2 s of a 2048^2 compare in all (measured on 5.2). numpy reads this at
# import, so it is set before anything imports it; a value the user set stays.
os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")

try:
    from .addon.command_line import leave
    from .harness.cli import main
    code = leave(main())
except KeyboardInterrupt:
    # Ctrl-C outside a command's own stop (interrupts.stoppable): while Python, numpy and
    # bpy load (about half a second), before anything is written. One line, not a traceback.
    print("surfgrad: interrupted by SIGINT: stopped; exit code 130", file=sys.stderr,
          flush=True)
    code = 130
sys.exit(code)
