"""`python -m surfgrad_addon ...`: the proving harness's command line (harness/cli.py), from a
checkout. Not part of the extension zip."""

import sys

from .addon.command_line import leave
from .harness.cli import main

sys.exit(leave(main()))
