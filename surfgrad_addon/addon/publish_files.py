"""Several finished files put under their final names as one result: every file new, or every
file as it was before.

A bake's UDIM tiles, compare-all's tables and heat maps, a staged output folder's entries are
one result each. Moved in one by one, a failure partway (something made in an output's place
after the checks, a folder that stopped taking files, a full disk) left new files beside old
ones under the final names with a raw OSError (red team 48b). Here each old file is kept as a
hidden hard link (a folder: renamed) until every new one is in place; on any failure the new
ones are taken out again and the old ones put back, and the failure names the file and the fix.
"""

import os
import re
import shutil
from pathlib import Path

from . import interrupts
from .exit_codes import MapNotWritten


def publish(pairs, overwrite, exists_error, folders=False):
    """Move each (temporary, final) of `pairs` to its final name, all or none. Without
    overwrite a final name that exists raises exists_error(final) and nothing is replaced.
    A folder in a final name's place is replaced only with `folders` (a staged output
    folder's entries); else it is refused. Any other failure raises MapNotWritten, every final
    name as before; the temporary files not moved in are the caller's to remove."""
    done = []                                  # [final, backup or None, moved in]
    try:
        for temp, final in pairs:
            temp, final = Path(temp), Path(final)
            if final.is_dir() and not final.is_symlink() and not folders:
                raise MapNotWritten(f"{str(final)!r} is a folder, made after the checks, where "
                                    f"an output file goes: remove it (or choose another "
                                    f"output name) and run again; every output is as it was")
            step = [final, None, False]
            done.append(step)
            if os.path.lexists(final):
                if not overwrite:
                    raise exists_error(final)
                step[1] = _set_aside(final)
            try:
                _move_in(temp, final, step[1] is not None and os.path.lexists(final))
            except FileExistsError:
                if overwrite:
                    raise
                raise exists_error(final) from None  # appeared since the check above
            step[2] = True
    except BaseException as err:
        stuck = _undo(done)
        if isinstance(err, OSError):
            failed = str(done[-1][0]) if done else "?"
            raise MapNotWritten(
                f"could not put {failed!r} in place ({err.strerror or err}): check that "
                f"{str(Path(failed).parent)!r} still takes files (its permissions, free space) "
                f"and that nothing else is in that file's place, and run again; "
                + ("every output is as it was" if not stuck else
                   f"these could not be put back: {'; '.join(stuck)}")) from None
        if stuck:
            err.add_note(f"surfgrad: these could not be put back: {'; '.join(stuck)}")
        raise
    for _, backup, _ in done:
        if backup is not None:
            remove_path(backup)


def _backup_name(final):
    return final.with_name(f".{final.name}{BACKUP_MARK}{os.getpid()}-{interrupts.PART_TOKEN}")


BACKUP_MARK = ".old-"


# Any run's backup (_backup_name): `.{name}.old-{pid}-{token}`
_ANY_BACKUP = re.compile(rf"\.(.+){re.escape(BACKUP_MARK)}\d+-[0-9a-f]{{{interrupts.PART_TOKEN_LENGTH}}}")


def others_backups(folder):
    """The (backup, final) pairs in `folder` kept aside by runs other than this process: left
    by runs killed while putting their files in place, or another run's under way."""
    own = f"{BACKUP_MARK}{os.getpid()}-{interrupts.PART_TOKEN}"
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    return [(Path(folder) / n, Path(folder) / m[1]) for n in names
            if (m := _ANY_BACKUP.fullmatch(n)) and not n.endswith(own)]


def backups_of(folder, run):
    """The (backup, final) pairs in `folder` that the run `run` ("PID-TOKEN") kept aside: a
    run killed while putting its files in place leaves them."""
    end = f"{BACKUP_MARK}{run}"
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return []
    return [(Path(folder) / n, Path(folder) / n[1:-len(end)]) for n in names
            if n.startswith(".") and n.endswith(end) and len(n) > len(end) + 1]


def _set_aside(final):
    """Keep the old file as a hidden hard link (never a moment with no file under the final
    name); a folder, or a disk without hard links: renamed."""
    backup = _backup_name(final)
    if final.is_dir() and not final.is_symlink():
        os.rename(final, backup)
        return backup
    try:
        os.link(final, backup, follow_symlinks=False)
    except OSError:
        os.rename(final, backup)
    return backup


def _move_in(temp, final, replace):
    if replace:                                # the old file's hard link is kept aside
        os.replace(temp, final)
        return
    try:
        os.link(temp, final)                   # fails if final appeared: nothing replaced
    except FileExistsError:                    # (not the fallback below)
        raise
    except OSError:                            # a folder, or no hard links (network shares)
        if os.path.lexists(final):
            raise FileExistsError(f"{final} exists") from None
        os.rename(temp, final)
        return
    temp.unlink()


def _undo(done):
    """Take out the new files and put the old ones back, last first; the names of those that
    could not be put back (a folder that stopped taking renames)."""
    stuck = []
    for final, backup, moved in reversed(done):
        try:
            if moved and backup is None:
                remove_path(final)
            elif backup is not None and not moved and os.path.lexists(final):
                remove_path(backup)                # a hard link of the old file, still in place
            elif backup is not None:
                if moved:
                    remove_path(final)
                os.rename(backup, final)
        except OSError as err:
            stuck.append(f"{final} (the old one is {backup}: {err.strerror})" if backup else
                         f"{final} ({err.strerror})")
    return stuck


def remove_path(path):
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()
    except FileNotFoundError:
        pass
