"""Write tests/interfaces.json from the socket specs (reference/group_interfaces.py): what
Blender must report for every group's interface. Run after changing a spec or an interface on
purpose: python tools/write_interfaces.py (no Blender needed)."""

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "interfaces.json"


def golden_text():
    from surfgrad_addon.reference.group_interfaces import expected_signatures
    return json.dumps(expected_signatures(), indent=1, sort_keys=True) + "\n"


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    GOLDEN.write_text(golden_text())
    print(f"wrote {GOLDEN}")
