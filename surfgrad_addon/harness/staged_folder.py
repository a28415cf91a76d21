"""An output folder written whole or not at all (the main job's out/demo).

The command writes into a hidden sibling, `.NAME.partial-PID-TOKEN`, and moves what it wrote into
the folder only at the end. A failure or a stop (Ctrl-C, SIGTERM) removes the sibling, so
the folder keeps exactly what it held before: a stopped rerun with --overwrite leaves the last
complete run in place, not a mix of two runs under the old report page. A run killed with
SIGKILL cannot remove its sibling: the next run into that folder removes those whose run is
provably gone (run_owner.py) and names the others, which may be live runs elsewhere.
"""

import errno
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

from ..addon import interrupts
from ..addon.exit_codes import BakeFailed
from ..addon.publish_files import backups_of, publish, remove_path
from . import run_owner


# Write errors that mean the disk (or the folder) took no more: a full disk, a quota, a
# file-size limit, a folder made read-only; None is numpy's short write ("N requested and M
# written"). Any other OSError (a missing input, say) is the run's own and passes unchanged.
_NO_ROOM = {None, *(getattr(errno, name, None)
                    for name in ("ENOSPC", "EDQUOT", "EFBIG", "EROFS", "EACCES", "EPERM"))}


def problem(final, overwrite):
    """Why `final` cannot take this run's files (None when it can): checked before any work."""
    final = Path(final)
    if final.exists() and not final.is_dir():
        return f"{final} is a file; the outputs need a folder there: choose another --out"
    if final.is_dir() and any(final.iterdir()) and not overwrite:
        return (f"{final} exists; pass --overwrite to replace what this run writes in it, or "
                f"choose another --out")
    return None


@contextmanager
def staged(final, overwrite):
    """Yield the folder to write into; at the block's end its entries replace those of the
    same name in `final` (made if missing). Raises FileExistsError before anything is made
    when `final` is a file, or holds files and not overwrite."""
    final = Path(os.path.abspath(final))          # "." and "out/" have a name this way
    why = problem(final, overwrite)
    if why:
        raise FileExistsError(why)
    made = [d for d in (final.parent, *final.parent.parents) if not d.exists()]
    final.parent.mkdir(parents=True, exist_ok=True)
    # Named by this process's id and token: another run's under the same id (a container's)
    # was removed here as if left by a killed process, and the two then shared one folder.
    work = final.parent / f".{final.name}.partial-{os.getpid()}-{interrupts.PART_TOKEN}"
    work.mkdir()
    run_owner.record(work)
    clear_leftovers(final, work)

    def forget(_signal_name=None):
        shutil.rmtree(work, ignore_errors=True)
        for d in made:                             # innermost first; only empty ones go
            try:
                d.rmdir()
            except OSError:
                break

    with interrupts.on_stop(forget):
        try:
            yield work
            with interrupts.committing():          # a stop waits for the move, whole
                _publish(work, final)
        except OSError as err:
            forget()
            if err.errno not in _NO_ROOM:
                raise
            # A full disk mid-run: numpy says only "N requested and M written", no file name.
            raise BakeFailed(f"the run could not write its files for {str(final)!r} ({err}): "
                             f"free space on that disk (or check the folder's permissions) "
                             f"and run again; {str(final)!r} is left as it was") from None
        except BaseException:
            forget()
            raise


def clear_leftovers(final, work, say=interrupts.say):
    """Remove the working folders of killed runs into `final` whose run is provably gone (one
    line each); name, once, those it cannot tell (another machine's or container's, or older
    than the record): a TD removes them once no run writes into `final`."""
    prefix = f".{final.name}.partial-"
    try:
        others = sorted(p for p in final.parent.iterdir()
                        if p.name.startswith(prefix) and p != work and p.is_dir() and
                        not p.is_symlink())
    except OSError:
        return
    unknown = []
    for other in others:
        if run_owner.gone(other):
            _clear_backups(final, other.name[len(prefix):], say)
            shutil.rmtree(other, ignore_errors=True)
            say(f"surfgrad: removed {other}, the working folder of a run on this machine "
                f"that was killed (its process has ended)")
        else:
            unknown.append(other.name)
    if unknown:
        say(f"surfgrad: note: {len(unknown)} working folder(s) of other runs beside "
            f"{str(final)!r} ({', '.join(unknown[:3])}{', ...' if len(unknown) > 3 else ''}) "
            f"may be runs under way on other machines, so they are left: once no run writes "
            f"into {str(final)!r}, remove them (rm -r {str(final.parent / prefix)}*)")


def _clear_backups(final, run, say):
    """Remove the old files the ended run `run` ("PID-TOKEN") kept aside in `final` (and, for
    compare-all's tables, beside it) while putting its files in place; one whose final name
    is gone is the only copy of that file: named, with the fix, not removed."""
    for folder in (final, final.parent):
        for backup, original in backups_of(folder, run):
            if os.path.lexists(original):
                remove_path(backup)
                say(f"surfgrad: removed {backup}, an old copy of {original.name} kept aside "
                    f"by a run on this machine that was killed (its process has ended)")
            else:
                say(f"surfgrad: note: {backup} is the only copy of {original}, kept aside by "
                    f"a run that was killed while putting its files in place: rename it back "
                    f"(mv {str(backup)!r} {str(original)!r}) or remove it")


def _publish(work, final):
    # The owner record stays until every file is in place: a run killed while moving them
    # in leaves old files aside (publish_files), removed later only once its run is gone.
    record = work / run_owner.RECORD_NAME
    if not final.exists():
        record.unlink()
        os.rename(work, final)
        return
    publish([(entry, final / entry.name) for entry in sorted(work.iterdir()) if entry != record],
            True, FileExistsError, folders=True)
    record.unlink()
    work.rmdir()


def shown(log, work, final):
    """`log` with the working folder's name replaced by the final one, so the messages name
    where the files will be."""
    return lambda text: log(str(text).replace(str(work), str(final)))
