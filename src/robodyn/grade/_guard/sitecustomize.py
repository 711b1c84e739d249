"""Loaded at the start of a submission's formula process (``robodyn grade`` puts this folder on PYTHONPATH).

It limits the process's address space (``RLIMIT_AS``, ``ROBODYN_GRADE_MEMORY`` bytes) and installs an
audit hook that refuses, while the submission's own file is on the call stack, what a formula never
needs: writing or deleting files, sockets, starting processes, ctypes.
"""

import os
import sys

_PATH = os.environ.get("ROBODYN_GRADE_GUARD", "")
_MEMORY = int(os.environ.get("ROBODYN_GRADE_MEMORY", "0") or 0)
_WRITE = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC
_REFUSED_IMPORTS = {"socket", "_socket", "ssl", "ctypes", "_ctypes", "multiprocessing", "urllib.request", "http.client"}
_REFUSED_PREFIXES = ("socket.", "subprocess.", "os.exec", "os.posix_spawn", "os.spawn", "os.fork", "os.kill", "shutil.")
_REFUSED = {"os.system", "os.remove", "os.unlink", "os.rename", "os.rmdir", "os.mkdir", "os.chmod", "os.truncate"}


def _in_submission():
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_code.co_filename == _PATH:
            return True
        frame = frame.f_back
    return False


def _refused(event, args):
    if event == "open":
        mode, flags = args[1], args[2]
        return (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
            mode is None and isinstance(flags, int) and flags & _WRITE
        )
    if event == "import":
        return args[0] in _REFUSED_IMPORTS
    return event in _REFUSED or event.startswith(_REFUSED_PREFIXES)


def _hook(event, args):
    if _refused(event, args) and _in_submission():
        what = f"import {args[0]}" if event == "import" else event
        raise PermissionError(f"{what} is not allowed in a graded submission")


if _MEMORY > 0:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (_MEMORY, _MEMORY))
if _PATH:
    sys.addaudithook(_hook)
