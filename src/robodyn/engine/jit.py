"""How robodyn's numba kernels are compiled and cached: one decorator, one cache key, one notice.

numba's ``cache=True`` keys a function's machine code on its own source file and bytecode only.
The kernels call each other across files (``tree.steps`` calls ``tree.algorithms``, which inlines
``tree.body``; ``closed_form`` compiles the closed forms of ``kinds`` and the step of ``rk4``), so
after an edit of a callee, or an upgrade of robodyn, the callers' cached code would still run the
old callee. Every kernel is therefore declared with :func:`njit`, whose cache lives in a folder of
its own for each :func:`cache_key` (robodyn's version and a hash of every file in :data:`KERNEL_SOURCES`):
``robodyn-<version>-<hash>/`` inside the folder numba would use (``NUMBA_CACHE_DIR`` when set,
else the ``__pycache__`` beside the sources, else numba's user-wide cache). Other keys' folders
there, unused for an hour, are removed when a new one is made.

A first compile on a machine takes tens of seconds to minutes. :func:`announce` says so once per
process, as a :class:`~robodyn.errors.CompileNotice` warning (library code never prints): the
command line prints it as one ``note:`` line on stderr, and a notebook shows it under the cell
that waits. numba is imported on first use, never at ``import robodyn``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import threading
import time
import warnings
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

from robodyn.errors import CompileNotice

# Every file whose code or constants a kernel compiles in: the kernels' own modules, the
# constants they read (tree/layout.py), and the closed forms and the RK4 step that closed_form.py compiles (kinds, rk4).
# tests/test_jit.py checks that each file declaring a kernel with njit is listed.
KERNEL_SOURCES = (
    "engine/closed_form.py",
    "engine/rk4.py",
    "engine/tree/body.py",
    "engine/tree/events.py",
    "engine/tree/flyer.py",
    "engine/tree/impacts.py",
    "engine/tree/algorithms.py",
    "engine/tree/layout.py",
    "engine/tree/local.py",
    "engine/tree/steps.py",
    "kinds/cart_pole.py",
    "kinds/formula.py",
    "kinds/geared_arm.py",
    "kinds/pendubot.py",
)
PREFIX = "robodyn-"
# Another key's folder written to within this long [s] may serve a process started before an
# edit or an upgrade: it is left for the next new key to remove.
IN_USE_S = 3600.0
HASH_CHARS = 16  # of the sources' sha256 in the key: 64 bits, no two edits alike in practice

WARMUP_HINT = "once per machine and robodyn version; `robodyn warmup` does it ahead"

# numba's type inference formats (and colours, with colorama) a message for every overload it
# tries and rejects: about 20,000 while the tree kernels compile, 5 s of CPU of a 34 s first run
# (measured). Without colour the messages are the same text. Read when numba is first imported,
# which no module does before this one (robodyn.engine imports it); a user's own setting stands.
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")


def cache_key(version: str, root: Path) -> str:
    """``<version>-<hash>``: the hash covers the bytes of every :data:`KERNEL_SOURCES` file under ``root``.

    Args:
        version: robodyn's version string.
        root: the folder of the ``robodyn`` package.
    """
    digest = hashlib.sha256()
    for name in KERNEL_SOURCES:
        digest.update(name.encode())
        digest.update((root / name).read_bytes())
    return f"{version}-{digest.hexdigest()[:HASH_CHARS]}"


@lru_cache(maxsize=1)
def current_key() -> str:
    """The cache key of the installed sources (computed once, at the first kernel declared).

    The version is the installed distribution's (``robodyn/__init__`` imports every layer, which
    this one may not); sources run without an install count as version ``unknown``.
    """
    from importlib import metadata

    try:
        version = metadata.version("robodyn")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return cache_key(version, Path(__file__).resolve().parents[1])


def _keyed(base: Any) -> Any:
    """Numba's cache locator ``base``, pointed at the :func:`current_key` folder inside its own."""

    class Keyed(base):  # type: ignore[misc, valid-type]
        def get_cache_path(self) -> str:
            return str(Path(super().get_cache_path()) / (PREFIX + current_key()))

        def ensure_cache_path(self) -> None:
            path = Path(self.get_cache_path())
            if not path.is_dir():  # a new key: the other keys' code can never run again here
                for old in path.parent.glob(PREFIX + "*"):
                    if time.time() - old.stat().st_mtime > IN_USE_S:
                        shutil.rmtree(old, ignore_errors=True)
            super().ensure_cache_path()

    Keyed.__name__ = Keyed.__qualname__ = f"Keyed{base.__name__}"
    return Keyed


@lru_cache(maxsize=1)
def _cache_class() -> Any:
    """Numba's per-function cache with every locator keyed (built once numba is imported)."""
    from numba.core import caching

    class KeyedImpl(caching.CompileResultCacheImpl):  # type: ignore[misc]
        _locator_classes = [_keyed(c) for c in caching.CompileResultCacheImpl._locator_classes]  # noqa: RUF012

    class KeyedCache(caching.FunctionCache):  # type: ignore[misc]
        _impl_class = KeyedImpl

        def _index_key(self, sig: Any, codegen: Any) -> Any:
            """The key numba would give, with the kernels a closure calls named rather than pickled.

            numba pickles a closure's cells, and a pickled dispatcher carries an id drawn anew in
            each process: the closures of :mod:`robodyn.engine.closed_form` missed the cache in every
            process. Within one key's folder a kernel's name says which code it is.
            """
            cells = self._py_func.__closure__ or ()
            names = [_cell_name(cell.cell_contents) for cell in cells]
            code = hashlib.sha256(self._py_func.__code__.co_code).hexdigest()
            return (sig, codegen.magic_tuple(), (code, hashlib.sha256("|".join(names).encode()).hexdigest()))

    return KeyedCache


def _cell_name(value: Any) -> str:
    """A closure cell in a cache key: a kernel by its module and name, anything else by its pickle."""
    func = getattr(value, "py_func", None)
    if func is not None:
        return f"{func.__module__}.{func.__qualname__}"
    from numba.core.serialize import dumps

    return hashlib.sha256(dumps(value)).hexdigest()


def njit(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(**options)`` with its cache in the :func:`current_key` folder.

    The one way a robodyn kernel is declared: ``@njit(nogil=True, error_model="numpy")``.
    """
    import numba

    if "cache" in options:
        raise TypeError("njit: every kernel is cached under the key of its sources; do not pass cache")

    def declare(func: Callable[..., Any]) -> Any:
        dispatcher = numba.njit(**options)(func)
        dispatcher._cache = _cache_class()(func)  # what numba's enable_caching() sets, keyed
        return dispatcher

    return declare


def is_cached(dispatcher: Any, where: Callable[[tuple[Any, ...]], bool] | None = None) -> bool:
    """True when ``dispatcher`` (declared with :func:`njit`) has compiled code in its cache folder.

    ``where``: only code compiled for an argument-type tuple it accepts counts (a kernel's variant,
    e.g. ``lambda sig: str(sig[3]) == "none"``), read from the cache's index.
    """
    cache = getattr(dispatcher, "_cache", None)
    path = getattr(cache, "cache_path", None)
    if cache is None or path is None:
        return False
    func = dispatcher.py_func
    stem = Path(func.__code__.co_filename).stem
    name = func.__qualname__.replace("<", "").replace(">", "")
    if not any(Path(path).glob(f"{stem}.{name}-*.nbi")):
        return False
    if where is None:
        return True
    try:
        index = cache._cache_file._load_index()  # numba's: {(argument types, target, code): data file}
    except Exception:  # an index numba cannot read is one it recompiles
        return False
    return any(where(key[0]) for key in index)


_ANNOUNCED: set[str] = set()


def announce(what: str, duration: str) -> None:
    """Warn once per process that ``what`` compiles now (``duration``: about how long it takes).

    Shown as ``compiling the tree-robot kernels for this machine (about a minute, once per machine
    and robodyn version; `robodyn warmup` does it ahead)``.
    """
    if what in _ANNOUNCED:
        return
    _ANNOUNCED.add(what)
    warnings.warn(f"compiling {what} for this machine ({duration}, {WARMUP_HINT})", CompileNotice, stacklevel=3)
    # the notes are the first one's followers: a filter on the module it is warned from (stacklevel 3) takes them too
    CompileWatch(what, module=sys._getframe(2).f_globals.get("__name__", __name__)).start()


# While a compile goes on, a further note this often [s] (no command is silent for a minute)...
STILL_EVERY = 20.0
# ...until numba has compiled nothing for this long [s] (or, if no compile starts, this long after the notice)
QUIET_S = 2.0
NEVER_STARTED_S = 30.0


class _Compiles:
    """numba's compiles under way in this process, counted from its compile events by one listener, never removed.

    Global on purpose: a listener removed while numba broadcasts an event to the list of listeners
    could make another miss the end of a compile and count it under way for ever. A forked child
    starts its own count (:func:`os.register_at_fork`): a lock held in the parent at the fork is
    never released in the child.
    """

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.depth = 0  # compiles under way (nested: a kernel's callees compile inside it)
        self.started = 0  # compiles begun since the process started
        self.quiet_since = time.monotonic()  # when the last one ended
        self.listening = False
        self.latest: CompileWatch | None = None  # the watch that notes

    def begin(self) -> None:
        with self.lock:
            self.depth += 1
            self.started += 1

    def end(self) -> None:
        with self.lock:
            self.depth = max(0, self.depth - 1)
            self.quiet_since = time.monotonic()

    def listen(self) -> None:
        """Register the one listener of numba's compile events (once per process)."""
        with self.lock:
            if self.listening:
                return
            self.listening = True
        from numba.core import event

        class Listener(event.Listener):  # type: ignore[misc]
            def on_start(self, event: Any) -> None:
                _COMPILES.begin()

            def on_end(self, event: Any) -> None:
                _COMPILES.end()

        event.register("numba:compile", Listener())

    def reset_in_child(self) -> None:
        """After a fork: a fresh lock and no watch (the listener, if any, stays registered and counts on)."""
        self.lock = threading.Lock()
        self.depth = 0
        self.latest = None


_COMPILES = _Compiles()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_COMPILES.reset_in_child)


def _notice_printer(what: str, module_name: str = __name__) -> Callable[[str], None] | None:
    """How a watch's notes on ``what`` reach the user, as warnings' filters and hook stand now; None: ignored.

    Taken in the thread that announced the compile, before it starts: numba compiles inside
    ``warnings.catch_warnings(record=True)`` and shows what it recorded only at the end, so a note
    warned from the watch thread during a compile would wait for it. The filters are read as
    :func:`warnings.warn` reads them, the first that matches the note's text decides
    (``PYTHONWARNINGS=ignore`` silences the notes, as it does the first one; ``error`` too, since a
    thread cannot raise into the command), a filter's module matched against ``module_name`` (the
    module the first notice was warned from); the hook is the current ``showwarning`` (the command
    line's prints one ``note:`` line), or the display that warnings' own hook calls.
    """
    text = f"still compiling {what}: "
    for action, message, category, module, lineno in warnings.filters:
        if (
            issubclass(CompileNotice, category)
            and (message is None or message.match(text))
            and (module is None or module.match(module_name))
            and lineno == 0
        ):
            if action in ("ignore", "error"):
                return None
            break
    show = warnings.showwarning
    if show is getattr(warnings, "_showwarning_orig", None):
        display = warnings._showwarnmsg_impl  # type: ignore[attr-defined]
        return lambda note: display(warnings.WarningMessage(CompileNotice(note), CompileNotice, __file__, 0))
    return lambda note: show(CompileNotice(note), CompileNotice, __file__, 0)


def compiling() -> bool:
    """True while numba compiles (a run's progress lines wait then: the compile's notes speak for it)."""
    return _COMPILES.depth > 0


class CompileWatch:
    """A thread that says ``still compiling WHAT: 40 s so far`` every STILL_EVERY s while numba compiles.

    It reads the process's count of numba's compiles under way (:class:`_Compiles`) and ends once
    none has run for QUIET_S seconds, or when a later watch starts. Its notes are
    :class:`CompileNotice` warnings, as the first one (the command line prints each as one ``note:``
    line), and come only while a compile is under way.
    """

    def __init__(self, what: str, *, every: float | None = None, module: str = __name__) -> None:
        self.what, self.every, self.module = what, STILL_EVERY if every is None else every, module
        self.begun = time.monotonic()
        self.started0 = _COMPILES.started  # a compile begun after this one counts
        self.show: Callable[[str], None] | None = None

    def start(self) -> None:
        """Take the notes' printer, make sure numba's compiles are counted, and watch from a daemon thread."""
        self.show = _notice_printer(self.what, self.module)  # here, outside numba's compile (which records warnings)
        _COMPILES.listen()
        _COMPILES.latest = self  # an earlier watch still running says no more: one note at a time
        threading.Thread(target=self._watch, name="robodyn-compile-watch", daemon=True).start()

    def _state(self, now: float) -> tuple[bool, bool]:
        """(over, compiling now)."""
        c = _COMPILES
        with c.lock:
            if c.depth > 0:
                return False, True
            if c.started == self.started0:
                return now - self.begun > NEVER_STARTED_S, False
            return now - c.quiet_since > QUIET_S, False

    def _watch(self) -> None:
        said = self.begun
        while _COMPILES.latest is self:
            time.sleep(min(0.5, self.every / 4.0))
            now = time.monotonic()
            over, busy = self._state(now)
            if over:
                return
            if busy and now - said >= self.every and _COMPILES.latest is self:
                said = now
                if self.show is not None:
                    self.show(f"still compiling {self.what}: {now - self.begun:.0f} s so far")
