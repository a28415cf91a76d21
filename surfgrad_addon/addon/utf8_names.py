"""Names given on a command line or in a batch entry that are not UTF-8.

A terminal or file in another encoding (Latin-1's 'R\\xf6ck' for 'Röck') reaches Python as
surrogates; Blender's names are UTF-8, and looking one up (`bpy.data.objects.get`) raised a
SystemError traceback (bake-normal-map, compare: exit 1; bake-batch failed the asset with
it). Paths are not checked here: a path may be any bytes."""


def problem(what, name):
    """None, or the problem when `name` (what names it, e.g. "--object") is not UTF-8."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        raw = name.encode("utf-8", "surrogateescape").decode("ascii", "backslashreplace")
        return (f"{what} '{raw}' is not UTF-8 text (a terminal or file in another encoding, "
                f"such as Latin-1?): Blender's names are UTF-8; give the name in UTF-8")
    return None
