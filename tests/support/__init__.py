"""Public helpers of the test suite: scene and bake probes (bake_probe, facts_probe), what a test
file that also runs as a script may import (blender), and the one runner for child interpreters
(child). Nothing here is part of the product."""
