"""`python -m surfgrad_addon ...`: the proving harness's command line (harness/cli.py), from a
checkout. Not part of the extension zip."""

import sys

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
