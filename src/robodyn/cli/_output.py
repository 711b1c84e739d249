"""Check where a command will write before it does the work (no file or folder is left behind).

Besides "can a file be written there", an output must not be one of the command's inputs
(``view t.npz --html t.npz`` would replace the trajectory by the page) nor another of its
outputs (``--out x.npz --csv x.npz``): :func:`refuse_clobbering` says which, in one line.
A run that stops early (diverged, interrupted) writes under :func:`partial_path`, so that a
complete result of an earlier run under the given name is never replaced by a partial one.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
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


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file.

    The same resolved path (links followed), or, when both exist, the same inode (a hard
    link, another spelling of the name on a case-insensitive disk).
    """
    try:
        if a.resolve() == b.resolve():
            return True
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except (OSError, ValueError, RuntimeError):  # a NUL byte in a name, a loop of links: no file to share
        return False


def same_entry(a: Path, b: Path) -> bool:
    """Whether writing ``a`` and writing ``b`` land on one name.

    A write renames a new file over the name (:func:`robodyn.fileio.write_atomically`): it
    replaces a link there rather than following it, so two outputs collide when their
    folders resolve to one and their names are the same (or, both existing, are one file in
    that folder under two spellings).
    """
    if a.parent.resolve() != b.parent.resolve():
        return False
    if a.name == b.name:
        return True
    try:
        return not a.is_symlink() and not b.is_symlink() and a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def refuse_clobbering(
    outputs: Iterable[tuple[str, Path | None]], inputs: Iterable[tuple[str, Path | None]] = ()
) -> None:
    """Raise :class:`InputError` when an output is one of the inputs, or two outputs are one file.

    An output that is an input by any route (the same path, a link to it, a hard link) is
    refused (:func:`same_file`); two outputs collide when they write one name
    (:func:`same_entry`). ``outputs`` and ``inputs`` are (label, path) pairs, the label saying where the path came
    from (``"--html"``, ``"the trajectory"``); None paths are skipped. Call it before any
    work, and again once the model is loaded (its URDF and SRDF are inputs too).
    """
    given = [(label, Path(path)) for label, path in outputs if path is not None]
    read = [(label, Path(path)) for label, path in inputs if path is not None]
    for k, (label, path) in enumerate(given):
        for in_label, source in read:
            if same_file(path, source):
                raise InputError(
                    f"cannot write {label} {path}: it is {in_label} {source}, an input of this command "
                    "(write the output elsewhere)"
                )
        for other_label, other in given[:k]:
            if same_entry(path, other):
                raise InputError(
                    f"cannot write {label} {path}: {other_label} {other} is the same file "
                    "(give each output its own path)"
                )


def partial_path(path: Path) -> Path:
    """Where a run that stopped early writes ``path``'s result: ``x.npz`` -> ``x.partial.npz``."""
    return path.with_name(f"{path.stem}.partial{path.suffix}")
