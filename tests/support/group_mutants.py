"""Mutants of the node groups for compare's mutation tests (test_faults_mutants57d, _58b): a
group builder run with one GroupBuilder method replaced, as a developer's slip would build it."""

from surfgrad_addon.addon import groups as G
from surfgrad_addon.addon import node_builder as NB


def while_building(mp, module, builder, attr, replacement):
    """module.builder (and groups' re-export of it), with GroupBuilder.attr replaced by
    `replacement` while it builds (every build: the build check's and the group's); `mp`:
    pytest's monkeypatch, which puts it back."""
    orig = getattr(module, builder)

    def build(*args, **kwargs):
        kept = getattr(NB.GroupBuilder, attr)
        setattr(NB.GroupBuilder, attr, replacement)
        try:
            return orig(*args, **kwargs)
        finally:
            setattr(NB.GroupBuilder, attr, kept)
    mp.setattr(module, builder, build)
    if hasattr(G, builder):
        mp.setattr(G, builder, build)
