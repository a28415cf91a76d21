"""Public helpers of the test suite: scene and bake probes (bake_probe, facts_probe), what a test
file that also runs as a script may import (blender), the one runner for child interpreters
(child), the operator tests' child sessions (operator_session), the bake tests' materials
(materials) and the main-line-only mark (lines). Nothing here is part of the product."""
