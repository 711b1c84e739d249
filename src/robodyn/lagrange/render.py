"""A derivation as text, as LaTeX, step by step, or as a ``KIND = "any"`` formula file.

Every function returns a string; the command line prints or writes it. Indices of M, C and G
are from 0, as ``robodyn check`` names entries; coordinates are q1, q2, ... in the formula's
order, v1, v2, ... their rates (v = dq/dt).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robodyn.lagrange.derivation import Derivation
from robodyn.lagrange.symbolic import Symbolic, sympy
from robodyn.lagrange.trig import Trig


def _coordinates(d: Derivation) -> str:
    """``q1 = shoulder + pi / 2 [rad], q2 = shoulder + elbow [rad]; v = dq/dt``: q = A q_urdf + b, as written."""
    lengths = [not a for a in d.angular]
    parts = d.coordinates.describe(lengths, lambda x: _float(x).replace("np.", ""), units=False)
    return ", ".join(f"{part} [{'m' if slide else 'rad'}]" for part, slide in zip(parts, lengths, strict=True)) + (
        "; v = dq/dt"
    )


def _param_lines(d: Derivation) -> list[str]:
    width = max((len(p.name) for p in d.params), default=1)
    values = [f"{p.value:.6g} {p.unit}" for p in d.params]
    room = max((len(v) for v in values), default=1)
    return [f"  {p.name:<{width}} = {v:<{room}}  {p.meaning}" for p, v in zip(d.params, values, strict=True)]


def text(s: Symbolic) -> str:
    """M, C, G, T and V as a textbook prints them, with the parameters' values."""
    d = s.derivation
    n = d.n
    lines = [
        f"{d.robot}: the Lagrangian of {n} joint{'s' if n > 1 else ''} ({', '.join(d.coordinates.joints)}), "
        f"derived symbolically in {d.wall_time_s:.2f} s",
        f"coordinates: {_coordinates(d)}",
        "parameters, read from the model (--format python writes them as parameters(robot)):",
        *_param_lines(d),
        "",
        "T = 1/2 v^T M(q) v",
        f"V = {s.sstr(s.V)}",
        "",
    ]
    for i in range(n):
        for j in range(i, n):
            name = f"M[{i},{j}]" if i == j else f"M[{i},{j}] = M[{j},{i}]"
            lines.append(f"{name} = {s.sstr(s.M[i, j])}")
    lines.append("")
    lines.append("C (Christoffel: C[i,j] = sum_k Gamma_ijk v_k, so dM/dt - 2C is skew):")
    zero = [f"C[{i},{j}]" for i in range(n) for j in range(n) if s.C[i, j] == 0]
    for i in range(n):
        for j in range(n):
            if s.C[i, j] != 0:
                lines.append(f"C[{i},{j}] = {s.sstr(s.C[i, j])}")
    if zero:
        lines.append(f"{', '.join(zero) if len(zero) <= 6 else f'the other {len(zero)} entries'} = 0")
    lines.append("")
    lines.extend(f"G[{i}] = {s.sstr(s.G[i, 0])}" for i in range(n))
    return "\n".join(lines)


def latex(s: Symbolic) -> str:
    """M, C, G, V in LaTeX (an ``align*`` block; v_k printed as dot q_k)."""
    sp = sympy()
    names = {v: rf"\dot{{q}}_{{{i + 1}}}" for i, v in enumerate(s.v)}

    def tex(expr: Any) -> str:
        return str(sp.latex(expr, symbol_names=names))

    n = s.derivation.n
    lines = [r"\begin{align*}", rf"V &= {tex(s.V)} \\"]
    for i in range(n):
        for j in range(i, n):
            lines.append(rf"M_{{{i + 1}{j + 1}}} &= {tex(s.M[i, j])} \\")
    for i in range(n):
        for j in range(n):
            if s.C[i, j] != 0:
                lines.append(rf"C_{{{i + 1}{j + 1}}} &= {tex(s.C[i, j])} \\")
    for i in range(n):
        lines.append(rf"G_{{{i + 1}}} &= {tex(s.G[i, 0])} {'' if i == n - 1 else chr(92) * 2}")
    lines.append(r"\end{align*}")
    return "\n".join(lines)


def steps(s: Symbolic) -> str:
    """The derivation step by step: centres of mass, their velocities, T, V, the Christoffel symbols, C and G."""
    d = s.derivation
    n = d.n
    out = [
        f"{d.robot}: the Lagrangian of {n} joint{'s' if n > 1 else ''}, step by step",
        f"coordinates: {_coordinates(d)}",
        "parameters, read from the model:",
        *_param_lines(d),
        "",
        "1. The centres of mass in the base frame:",
    ]
    for b in range(n):
        r = [s.expression(x) for x in d.com[b]]
        out.append(f"   r{b + 1} = [{', '.join(s.sstr(x) for x in r)}]")
    out.append("")
    out.append("2. Their velocities, dr/dt = sum_k (dr/dq_k) v_k:")
    for b in range(n):
        vel = [s.expression(Trig(d.n_angles), [(d.d(x, k), s.v[k]) for k in range(n)]) for x in d.com[b]]
        out.append(f"   dr{b + 1}/dt = [{', '.join(s.sstr(x) for x in vel)}]")
    out.append("")
    out.append("3. The angular velocities, in each link's own axes:")
    for b in range(n):
        w = [
            s.expression(Trig(d.n_angles), [(d.angular_velocity[b][k][a], s.v[k]) for k in range(n)]) for a in range(3)
        ]
        out.append(f"   w{b + 1} = [{', '.join(s.sstr(x) for x in w)}]")
    out.append("")
    out.append("4. The kinetic energy T = sum_b 1/2 m_b |dr_b/dt|^2 + 1/2 w_b^T I_b w_b = 1/2 v^T M(q) v:")
    for i in range(n):
        for j in range(i, n):
            out.append(f"   M[{i},{j}] = {s.sstr(s.M[i, j])}")
    out.append("")
    out.append("5. The potential energy V = -sum_b m_b (g . r_b):")
    out.append(f"   V = {s.sstr(s.V)}")
    out.append("")
    out.append(
        "6. The Christoffel symbols Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) (Gamma_ikj = Gamma_ijk):"
    )
    if not s.gamma:
        out.append("   all zero: M does not depend on q")
    for (i, j, k), g in s.gamma.items():
        out.append(f"   Gamma_{i + 1}{j + 1}{k + 1} = {s.sstr(g)}")
    out.append("")
    out.append("7. C[i,j] = sum_k Gamma_ijk v_k and G = dV/dq:")
    for i in range(n):
        for j in range(n):
            if s.C[i, j] != 0:
                out.append(f"   C[{i},{j}] = {s.sstr(s.C[i, j])}")
    out.extend(f"   G[{i}] = {s.sstr(s.G[i, 0])}" for i in range(n))
    return "\n".join(out)


def python(
    s: Symbolic,
    *,
    model: str,
    out: str,
    coordinates_file: str | None,
    version: str,
    locked: dict[str, float] | None = None,
) -> str:
    """A ``KIND = "any"`` formula file that ``robodyn check MODEL --formula FILE`` passes."""
    sp = sympy()
    from sympy.printing.numpy import NumPyPrinter

    printer = NumPyPrinter({"fully_qualified_modules": False, **s.printer_settings()})
    d = s.derivation
    n = d.n
    given = f" --coordinates {coordinates_file}" if coordinates_file else ""
    joints = ", ".join(repr(joint) for joint in d.coordinates.joints)
    lines = [
        f'"""The Lagrangian of {d.robot}, derived by robodyn {version}: robodyn derive {model}{given} --format python.',
        "",
        f"Check it:  robodyn check {model} --formula {out}",
        "",
        f"Coordinates: {_coordinates(d)}.",
        "The parameters are read from the model by parameters(robot), robodyn's per-link table.",
        '"""',
        "",
        "import numpy as np",
        "from numpy import cos, sin",
        "",
        'KIND = "any"',
        f"JOINTS = [{joints}]",
    ]
    lines += _coordinate_lines(d)
    if locked:
        held = ", ".join(f"{joint!r}: {_float(x)}" for joint, x in locked.items())
        lines.append(f"LOCKED = {{{held}}}  # the other joints are held at the neutral pose")
    lines += [
        "",
        "",
        "def parameters(robot):",
        '    """The parameters of the derivation, read from the per-link table."""',
    ]
    lines.append("    return {")
    for p in d.params:
        lines.append(f"        {p.name!r}: {p.code},  # {p.unit}, {p.meaning}")
    lines += ["    }", ""]

    def body(name: str, signature: str, expr: Any, *, matrix: bool, doc: str) -> list[str]:
        code = [f"def {name}({signature}):", f'    """{doc}"""']
        used = {str(x) for x in expr.free_symbols}
        code.append(f"    {', '.join(str(x) for x in s.q)}{',' if n == 1 else ''} = q")
        if "v" in signature:
            code.append(f"    {', '.join(str(x) for x in s.v)}{',' if n == 1 else ''} = v")
        names = [p.name for p in d.params if p.name in used]
        if names:
            code.append(f"    {', '.join(names)} = {', '.join(f'p[{k!r}]' for k in names)}")
        if matrix:
            rows = []
            for i in range(expr.rows):
                cells = ", ".join(_code(printer, expr[i, j]) for j in range(expr.cols))
                rows.append(f"        [{cells}],")
            code += ["    return np.array(", "        [", *["    " + r for r in rows], "        ]", "    )"]
        elif getattr(expr, "cols", None) == 1:
            cells = ", ".join(_code(printer, expr[i, 0]) for i in range(expr.rows))
            code.append(f"    return np.array([{cells}])")
        else:
            code.append(f"    return {_code(printer, expr)}")
        return [*code, "", ""]

    lines += [""]
    lines += body("mass_matrix", "q, p", s.M, matrix=True, doc="M(q) [kg m^2 | kg], shape (n, n).")
    lines += body("coriolis_matrix", "q, v, p", s.C, matrix=True, doc="The Christoffel C(q, v), shape (n, n).")
    lines += body("gravity", "q, p", s.G, matrix=False, doc="G(q) = dV/dq [N m | N], shape (n,).")
    lines += body("potential_energy", "q, p", s.V, matrix=False, doc="V(q) [J].")
    del sp
    return "\n".join(lines).rstrip() + "\n"


def _coordinate_lines(d: Derivation) -> list[str]:
    """COORDINATES (and OFFSETS) as the ``--coordinates`` file gave them: the sign form, or the matrix."""
    cmap = d.coordinates
    if cmap.diagonal:
        if np.array_equal(cmap.A, np.eye(d.n)) and not cmap.b.any():
            return []
        pairs = zip(cmap.joints, cmap.signs, cmap.b, strict=True)
        entries = ", ".join(f"{joint!r}: ({sign:g}, {_float(offset)})" for joint, sign, offset in pairs)
        return [f"COORDINATES = {{{entries}}}  # q = sign * q_urdf + offset"]
    rows = ", ".join("[" + ", ".join(_entry(x) for x in row) + "]" for row in cmap.A)
    lines = [f"COORDINATES = [{rows}]  # q = A q_urdf + OFFSETS, q_urdf in the order of JOINTS"]
    if cmap.b.any():
        lines.append(f"OFFSETS = [{', '.join(_float(x) for x in cmap.b)}]")
    return lines


def _entry(x: float) -> str:
    """A matrix entry as Python: ``1``, ``-1``, or every digit of a float (it round-trips)."""
    return f"{int(x)}" if float(x).is_integer() else repr(float(x))


def _code(printer: Any, expr: Any) -> str:
    """An expression as NumPy code, floats kept to 17 digits (float(repr) round-trips)."""
    text = printer.doprint(expr)
    return "0.0" if text == "0" else text


def _float(x: float) -> str:
    if x and abs(abs(x) / math.pi - round(abs(x) / math.pi * 4) / 4) < 1e-15:
        k = round(x / math.pi * 4)
        return {2: "np.pi / 2", -2: "-np.pi / 2", 4: "np.pi", -4: "-np.pi", 1: "np.pi / 4", -1: "-np.pi / 4"}.get(
            k, repr(x)
        )
    return repr(float(x))
