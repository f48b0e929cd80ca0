"""The `rt` program: the console script and `python -m rt`.

Python's cyclic garbage collector is kept out of the program's way from its first import to its
end. Start-up (Numba, pydantic, typer, the scene's models) makes several hundred thousand
objects that live until the process ends; the collector's passes over them freed nothing.
Measured on a 2-core machine, whole processes: its passes during the imports cost 5 to 9% of a
small warm render, and the interpreter's shutdown, which collects while it tears the modules
down, took 0.2 to 0.3 s to end the process. Frozen objects are ignored by every later pass.
A command makes few reference cycles, and the process ends soon after. This is the one place
that decides the collector's state: `rt.cli.app`, which tests run in their own process, leaves
it alone.

`rt render` runs in two processes where that gains time (see split.py).
"""

import gc
import sys


def run() -> None:
    gc.disable()
    try:
        from . import split

        if split.can_split(sys.argv):
            sys.exit(split.run())
        from .cli import app

        app(prog_name="rt")
    finally:
        gc.freeze()


if __name__ == "__main__":
    run()
