"""The package itself: light to import, curated public names, built-in models shipped."""

from __future__ import annotations

import subprocess
import sys

import robodyn

HEAVY = ("pinocchio", "matplotlib", "meshcat", "sympy", "numba", "mujoco", "scipy")


def test_import_and_cli_parser_stay_light():
    code = (
        "import sys, robodyn, robodyn.cli; robodyn.cli.get_argument_parser(); "
        f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"heavy modules loaded at import time: {out}"


def test_public_names_resolve_and_are_sorted():
    assert robodyn.__all__ == sorted(robodyn.__all__)
    for name in robodyn.__all__:
        assert getattr(robodyn, name) is not None, name
    assert robodyn.__version__.count(".") == 2


def test_builtin_models_are_found_from_the_installed_package():
    from robodyn.model.files import BUILTIN_NAMES, models_dir

    for name in BUILTIN_NAMES:
        assert (models_dir() / f"{name}.urdf").is_file()


def test_unknown_attribute_is_an_attribute_error():
    try:
        robodyn.does_not_exist  # noqa: B018
    except AttributeError as exc:
        assert "does_not_exist" in str(exc)
    else:
        raise AssertionError("expected AttributeError")
