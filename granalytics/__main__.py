"""``python -m granalytics`` and the ``granalytics`` console script (``pyproject.toml``).

The commands' modules take a second or two to import (pandas, numba, h5py); Ctrl-C is handled
from the first instant, also while they load: one line and exit status 130, never a traceback.
While they load, a Ctrl-C is held and acted on once they are loaded
(:func:`granalytics.base.interrupts.interrupts_held`).
Once the command has finished (its outputs written whole, its table printed) the process still
takes half a second to shut down (numba, llvmlite and the modules are torn down); a Ctrl-C then
interrupts nothing, and it is ignored: the exit status is the command's, never a KeyboardInterrupt
"ignored" at exit with status 0 or a silent death by SIGINT.
"""

import signal
import sys

from granalytics.base.interrupts import interrupts_held
from granalytics.base.progress import throttle_bars_off_terminal

throttle_bars_off_terminal()  # before anything imports tqdm


def main(argv=None) -> int:
    """Run the command line (:func:`granalytics.cli.main`); returns the exit status. Called
    without ``argv`` (the process's own command line: the console script, ``python -m``), a
    Ctrl-C after the command finished is ignored while the process exits."""
    loaded = sys.modules.get("granalytics.cli")
    if loaded is not None:  # a command run earlier in this process (tests) says nothing of this one
        loaded.finished = None
    try:
        with interrupts_held() as held:
            from granalytics.cli import main as run
        if held:
            raise KeyboardInterrupt
        status = run(argv)
    except KeyboardInterrupt:
        done = getattr(sys.modules.get("granalytics.cli"), "finished", None)
        if done is None:  # before a command started (it handles its own): nothing was written
            print("granalytics: interrupted before any work; nothing was written", file=sys.stderr)
            return 130
        status = done  # as the finished command returned: it is done, its status stands
    if argv is None:
        _ignore_interrupts_from_now()
    return status


def _ignore_interrupts_from_now() -> None:
    """Ignore SIGINT for the rest of the process (its shutdown): the command is done."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":
    sys.exit(main())
