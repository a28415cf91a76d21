"""How a child process ended, in words a user can act on: a worker killed by a signal was
reported as "exit -9", which names neither the signal nor what to do (red team 43a)."""

import signal

KILL = getattr(signal, "SIGKILL", None)


def how_it_ended(code, exited="exit"):
    """'exit N' (`exited` N) for a process that exited; for one ended by a signal
    (subprocess's negative return code) its name and, for SIGKILL, the likely cause and fix."""
    if code is None or code >= 0:
        return f"{exited} {code}"
    try:
        name = signal.Signals(-code).name
    except ValueError:
        name = f"signal {-code}"
    if -code == KILL:
        return (f"killed by {name}, most likely the out-of-memory killer (see `dmesg` or the "
                f"job's memory use): free memory, or run fewer --workers or a lower "
                f"--resolution, and run again")
    return f"killed by {name}"
