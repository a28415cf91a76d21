"""Whether two of a batch's output paths name one file: on a file system that ignores case
(macOS and Windows by default, many SMB shares), `Rock.png` and `rock.png` are one file, and
the second asset's map would replace the first's with exit 0; so are `Café.png` with the é as
one character (NFC) and as e and an accent (NFD, as macOS writes names) where it ignores
Unicode's normal forms (APFS, HFS+, an SMB share of them). The file system is asked, not
assumed: a probe file is made in the nearest folder that exists and looked up in another case
(another normal form)."""

import os
import unicodedata
import uuid
from pathlib import Path


# The probes: a name, and the same name as the file system may take it for another
CASE = ("case", lambda hexa: f".surfgrad-case-probe-{hexa}", str.upper)
FORMS = ("form", lambda hexa: f".surfgrad-form-probe-\u00e9-{hexa}",
         lambda name: unicodedata.normalize("NFD", name))


def ignores_case(folder):
    """True when the file system holding `folder` (or its nearest existing parent) finds a file
    under a name in another case; False where it does not, or where no probe can be made (the
    output checks name an unwritable folder on their own)."""
    return _probe(_existing(folder), CASE)


def ignores_forms(folder):
    """True when that file system finds a file whose name holds an é (NFC) under the name
    with e and a combining accent (NFD): one file for names in either form."""
    return _probe(_existing(folder), FORMS)


def _existing(folder):
    folder = Path(folder)
    while not _is_dir(folder) and folder.parent != folder:
        folder = folder.parent
    return str(folder)


_ANSWERS = {}


def _probe(existing, kind):
    """One probe per existing folder and kind (a batch's outputs mostly share one), not one per
    asset; a folder where no probe could be made is asked again next time (it may take files
    then)."""
    key, name_of, other = kind
    if (existing, key) in _ANSWERS:
        return _ANSWERS[existing, key]
    folder = Path(existing)
    probe = folder / name_of(uuid.uuid4().hex)
    try:
        probe.touch(exist_ok=False)
    except (OSError, UnicodeEncodeError):      # (a file system that takes no such name)
        return False
    try:
        _ANSWERS[existing, key] = os.path.exists(folder / other(probe.name))
    finally:
        probe.unlink(missing_ok=True)
    return _ANSWERS[existing, key]


def _is_dir(path):
    try:
        return path.is_dir()
    except OSError:                 # a name too long for the file system: the checks say so
        return False


def output_key(path):
    """The key under which two outputs collide: the path, in one normal form where its file
    system ignores forms, folded in case where it ignores case."""
    folder, key = str(Path(path).parent), str(path)
    if ignores_forms(folder):
        key = unicodedata.normalize("NFC", key)
    return key.casefold() if ignores_case(folder) else key


def one_file_because(a, b):
    """Why outputs `a` and `b` (different names, one output_key) are one file."""
    forms = ("it does not tell Unicode's normal forms apart: an accent as part of a letter "
             "or as a character of its own, as macOS writes names")
    if unicodedata.normalize("NFC", a) == unicodedata.normalize("NFC", b):
        return forms
    return "it ignores case" if a.casefold() == b.casefold() else f"it ignores case, and {forms}"
