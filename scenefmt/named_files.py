"""Where a file a scene names is: one rule for included files, images, environment maps and meshes.

A name is relative to the folder of the file that writes it: a mesh named in `parts/robot.yaml`,
which the main scene includes, is looked for in `parts/`, as that file's images and includes
are; an absolute name stands as it is. Wherever it is found, the file must resolve (symbolic
links followed) inside the folders the scene may read from (`files.reading_within`: the main
scene's folder and those `--allow-path` adds), checked before it is even looked for. Every
name looked up is recorded (`files.record_read`), found or not: that list is what `rt watch`
polls (creating a missing file counts as a change) and what a cluster client sends its workers.

`locate_named_file` is the rule; the callers (`graph.py` for images, environment maps and
meshes, `includes.py` for included files) only say which folder the naming file is in and
what kind of file it is, so that every kind is refused with the same sentence.
"""

from __future__ import annotations

import os
from pathlib import Path

from .files import describe_os_error, outside_problem, path_problem, record_read


class NamedFileProblem(Exception):
    """A named file cannot be used; the message is the whole sentence, starting with the kind of
    file and its name as the scene wrote it ("mesh file 'parts/arm.obj' not found ...")."""


def locate_named_file(kind: str, name: str, folder: Path) -> Path:
    """The real path of the file that a scene file in `folder` names `name`; `kind` ("image file",
    "mesh file", "included file") starts every message. Raises `NamedFileProblem` if the name is
    unusable, resolves outside the allowed folders, or names nothing."""
    problem = path_problem(name)
    if problem:
        raise NamedFileProblem(f"{kind} {name!r}: {problem}")
    named = Path(folder) / name
    outside = outside_problem(named)  # as written: the message says when a link leads out
    if outside:
        raise NamedFileProblem(f"{kind} '{name}' is {outside}")
    try:
        resolved = named.resolve()
        exists = resolved.exists()
    except (OSError, RuntimeError, ValueError) as exc:  # a loop of symbolic links, a name too long
        reason = describe_os_error(exc) if isinstance(exc, OSError) else "the path runs through a loop of symbolic links"
        raise NamedFileProblem(f"{kind} {name!r}: {reason}") from None
    # As written (its absolute path, links kept): a cluster's workers get the file under this
    # name, so the scene's own name for it resolves there too. Reading it records where it led.
    record_read(os.path.abspath(named))
    if not exists:
        raise NamedFileProblem(f"{kind} '{name}' not found (looked for {resolved})")
    return resolved
