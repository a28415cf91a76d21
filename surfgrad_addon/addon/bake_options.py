"""The bake subcommands' options, built from the bake request's fields (bake_request.py): each
option's default, range, choices and help are the request's, written once there."""

from dataclasses import MISSING, fields

from .bake_request import BakeRequest

FIELDS = {f.name: f for f in fields(BakeRequest)}


def option_name(name):
    return FIELDS[name].metadata.get("option") or "--" + name.replace("_", "-")


def _help(f, text):
    """The help with the request's default (unless None or a flag's False) and range."""
    shown = not any(f.default is v for v in (None, False, MISSING))
    said = [f"default {f.default}"] if shown and f"default {f.default}" not in text else []
    if "range" in f.metadata:
        said.append("{} to {}".format(*f.metadata["range"]))
    return f"{text} ({'; '.join(said)})" if said else text


def add(parser, names, unset=False, helps=None):
    """Add the request fields `names` to `parser` as options. unset: the option's default is
    None (a bake-batch setting left to the settings file, then the request); its help still
    names the request's default. helps: other help text for some fields (same defaults)."""
    for name in names:
        f = FIELDS[name]
        meta, text = f.metadata, (helps or {}).get(name, f.metadata["help"])
        kw = {"dest": name, "help": _help(f, text)}
        if f.type is bool:
            kw["action"] = "store_true"
            if unset:
                kw["default"] = None
        else:
            kw["default"] = None if unset else f.default
            if "choices" in meta:
                kw["choices"] = meta["choices"]
            else:
                kw["type"] = meta.get("type", f.type)
        parser.add_argument(option_name(name), **kw)
