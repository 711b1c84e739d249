"""The URDF files of eight robot-description packages on PyPI, found where they are installed.

None of them is a robodyn dependency: each is installed as data, ``pip install --no-deps PACKAGE``
into the environment that runs the benchmark. example-robot-data-jnrh2023 installs the same
``example_robot_data`` module as example-robot-data, so it goes into a folder of its own,
``pip install --no-deps --target DIR example-robot-data-jnrh2023``, given as ``--jnrh2023 DIR``.
A corpus that is not installed is reported absent, with the command that installs it.
"""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Corpus:
    """One package: its PyPI name, the module it installs, and where its data lies below that."""

    name: str  # the PyPI name, also the set's name
    module: str
    data: str  # "package": the module's folder; "share/X": sys.prefix/share/X

    def root(self, jnrh2023: Path | None) -> Path | None:
        """The folder holding the package's URDF files, or None when it is not installed."""
        if self.name == "example-robot-data-jnrh2023":
            if jnrh2023 is None:
                return None
            folder = jnrh2023 / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
            return folder if folder.is_dir() else None
        spec = importlib.util.find_spec(self.module)
        if spec is None or not spec.submodule_search_locations:
            return None
        if self.data == "package":
            return Path(next(iter(spec.submodule_search_locations)))
        folder = Path(sys.prefix) / self.data
        return folder if folder.is_dir() else None

    def install(self) -> str:
        """The command that installs it as data."""
        if self.name == "example-robot-data-jnrh2023":
            return f"pip install --no-deps --target DIR {self.name}, then --jnrh2023 DIR"
        return f"pip install --no-deps {self.name}"


CORPORA = (
    Corpus("icub-models", "icub_models", "share/iCub"),
    Corpus("armar", "armar", "package"),
    Corpus("jvrc-description", "jvrc_description", "package"),
    Corpus("airo-models", "airo_models", "package"),
    Corpus("gb-robot-models", "gb_robot_models", "share/gb_robot_models"),
    Corpus("hello-robot-stretch-urdf", "stretch_urdf", "package"),
    Corpus("dexmate-urdf", "dexmate_urdf", "package"),
    Corpus("example-robot-data-jnrh2023", "example_robot_data", "jnrh2023"),
)
NAMES = tuple(c.name for c in CORPORA)


def corpus_files(name: str, jnrh2023: Path | None) -> tuple[Path | None, list[Path]]:
    """(root, every ``.urdf`` below it, sorted) of the corpus ``name``; (None, []) when not installed."""
    corpus = next(c for c in CORPORA if c.name == name)
    root = corpus.root(jnrh2023)
    return root, (sorted(root.glob("**/*.urdf")) if root is not None else [])


def absent(names: list[str], jnrh2023: Path | None) -> dict[str, str]:
    """The chosen corpora that are not installed, each with the command that installs it."""
    return {c.name: c.install() for c in CORPORA if c.name in names and c.root(jnrh2023) is None}
