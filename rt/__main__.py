"""The `rt` program: the console script and `python -m rt`.

Python's cyclic garbage collector is kept out of the program's way from its first import to its
end. Start-up (Numba, pydantic, typer, the scene's models) makes several hundred thousand
objects that live until the process ends, and the collector's passes over them free nothing;
frozen objects are ignored by every later pass, including those of the interpreter's shutdown.
A command makes few reference cycles, and the process ends soon after. This is the one place
that decides the collector's state: `rt.cli.app`, which tests run in their own process, leaves
it alone.
"""

import gc


def run() -> None:
    gc.disable()
    try:
        from .rendering import limit_blas_threads

        limit_blas_threads()  # before anything imports numpy
        from .cli import app

        app(prog_name="rt")
    finally:
        gc.freeze()


if __name__ == "__main__":
    run()
