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


def test_check_stays_the_function_once_the_checker_package_is_imported():
    # A subpackage named like a public function would replace it on first import: robodyn.check is
    # the function, robodyn.checker the package. Fresh process: an earlier test may have imported either.
    code = (
        "import robodyn, robodyn.checker.compare, robodyn.checker.rows; "
        "print(robodyn.check is robodyn.checker.compare.check, robodyn.CheckReport is robodyn.checker.rows.CheckReport)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "True True"


# ------------------------------------------------------------------ the house
MAX_MODULE_LINES = 520  # "about 500": a module past this holds more than one concept


def _graph():
    import grimp

    return grimp.build_graph("robodyn", include_external_packages=False)


def test_no_module_imports_one_that_imports_it_back():
    """No import cycle between robodyn's modules, counting function-local and TYPE_CHECKING imports.

    grimp reads every import statement of a module; a cycle is a strongly connected component of
    more than one module (Tarjan's algorithm).
    """
    graph = _graph()
    modules = sorted(graph.modules)
    edges = {m: sorted(graph.find_modules_directly_imported_by(m) & graph.modules) for m in modules}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for m in modules:
        if m not in index:
            visit(m)
    assert cycles == [], f"import cycles: {cycles}"


def test_every_module_states_its_concept_and_stays_small():
    import ast
    from pathlib import Path

    root = Path(robodyn.__file__).parent
    too_long, no_doc = [], []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if len(text.splitlines()) > MAX_MODULE_LINES:
            too_long.append(f"{path.relative_to(root)} ({len(text.splitlines())} lines)")
        if not ast.get_docstring(ast.parse(text)):
            no_doc.append(str(path.relative_to(root)))
    assert too_long == [], f"modules over {MAX_MODULE_LINES} lines: {too_long}"
    assert no_doc == [], f"modules without a docstring: {no_doc}"


def test_no_module_imports_robodyn_through_importlib():
    """Every import of robodyn is a statement import-linter and grimp can see.

    ``importlib.import_module("robodyn.x")`` hid an upward edge (``Robot.view`` reached the viewer
    that way) and robodyn 0.1's alias finder forwarded old paths; both are gone.
    """
    import ast
    from pathlib import Path

    root = Path(robodyn.__file__).parent
    hidden = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                name = ast.unparse(node.func)
                if name.endswith(("import_module", "__import__", "MetaPathFinder")) or "meta_path" in name:
                    hidden.append(f"{path.relative_to(root)}:{node.lineno}: {ast.unparse(node)}")
            if isinstance(node, ast.Attribute) and node.attr == "meta_path":
                hidden.append(f"{path.relative_to(root)}:{node.lineno}: sys.meta_path")
    assert hidden == [], hidden


def test_robodyn_0_1_import_paths_and_robot_view_are_gone():
    """Their one release is over: the old paths fail to import, and Robot has no ``view``."""
    code = (
        "import robodyn, importlib\n"
        "for old in ('robodyn.simulation', 'robodyn.crosscheck', 'robodyn.formulas', 'robodyn.fast'):\n"
        "    try:\n"
        "        importlib.import_module(old)\n"
        "    except ModuleNotFoundError:\n"
        "        continue\n"
        "    raise SystemExit(f'{old} still imports')\n"
        "print(hasattr(robodyn.Robot, 'view'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "False", (out.stdout, out.stderr)


def test_layout_page_gives_the_layers_ci_checks():
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    config = (root / "pyproject.toml").read_text(encoding="utf-8")  # no tomllib: Python 3.10 is supported
    listed = re.search(r'type = "layers"\nlayers = \[(.*?)\]', config, re.S)
    assert listed is not None, "pyproject.toml no longer has the layers contract"
    checked = re.findall(r'"([^"]+)"', listed.group(1))
    page = " ".join((root / "docs" / "reference" / "layout.md").read_text(encoding="utf-8").split())
    stated = re.search(r"as `lint-imports` checks them, are (.*?): a module imports", page)
    assert stated is not None, "docs/reference/layout.md no longer states the layer order"
    documented = [layer.strip().strip("`") for layer in stated.group(1).split(" > ")]
    assert documented == [layer.replace("robodyn.", "") for layer in checked]
