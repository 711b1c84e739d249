"""Check where a command will write before it does the work (no file or folder is left behind)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from robodyn.errors import InputError


def _existing_ancestor(path: Path) -> Path:
    """The nearest folder of ``path`` that exists (the folders below it will be created)."""
    parent = path.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    return parent


def _check_folder_writable(folder: Path, target: Path) -> None:
    if not folder.is_dir():
        what = "a file, not a folder" if folder.exists() else "not a folder"
        raise InputError(f"cannot write {target}: {folder} is {what}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot write {target}: folder {folder} is not writable")
    # Permission bits do not tell everything (root in /proc, a read-only mount): open an
    # anonymous file there (O_TMPFILE on Linux: it never gets a name) and let it go.
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise InputError(f"cannot write {target}: folder {folder} takes no files ({exc.strerror})") from None


def check_output_file(path: Path) -> Path:
    """Raise :class:`InputError` unless a file can be written at ``path``; create nothing.

    ``path`` must not be a folder; its folder must exist and be writable, or be creatable
    (its nearest existing ancestor is a writable folder). An existing file must be writable.
    """
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder (expected a file name)")
    if path.exists():
        if not os.access(path, os.W_OK):
            raise InputError(f"cannot write {path}: the file is not writable")
        return path
    _check_folder_writable(_existing_ancestor(path), path)
    return path


def check_output_folder(folder: Path) -> Path:
    """Raise :class:`InputError` unless files can be written in ``folder``; create nothing.

    ``folder`` must be a writable folder, or not exist yet below a writable folder.
    """
    if folder.exists():
        _check_folder_writable(folder, folder)
        return folder
    _check_folder_writable(_existing_ancestor(folder), folder)
    return folder


def writable_path(path: Path, *, create_parents: bool = True, suffix: str | None = None) -> Path:
    """Return ``path`` after checking, without writing a file, that it can be written.

    As :func:`check_output_file`; ``suffix`` (e.g. ``".npz"``) is required of the name when
    given. Missing parent folders are then created when ``create_parents`` (the default;
    ``robodyn simulate`` refuses them instead). A run that fails later leaves no file behind.

    Raises:
        InputError: one line naming the path and what is wrong with it.
    """
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder (expected a file name)")
    if suffix is not None and path.suffix != suffix:
        raise InputError(f"cannot write {path}: expected a {suffix} path (got {path.suffix or 'no suffix'})")
    parent = path.absolute().parent
    if not create_parents and not parent.exists():
        raise InputError(f"cannot write {path}: the folder {path.parent} does not exist (create it first)")
    check_output_file(path)
    if create_parents:
        parent.mkdir(parents=True, exist_ok=True)
    return path
