"""robodyn grade on a generated class: wall time per submission, and every planted score checked.

    python benchmarks/bench_grade.py --students 300 --jobs 2

The class is spread over three robots (a double pendulum in two coordinate conventions, a dict and
a matrix COORDINATES; the Pendubot with a Christoffel C and with C v; a three-link arm in absolute
angles), each with right answers, single and double planted slips and hostile files (a loop, an exit,
a file write, a socket, a NaN). It prints the wall time, the rate and the submissions whose score was
not the planted one (there must be none), the CPU time of every process it started (the wall time on a shared
machine measures its load too), and saves ``bench_grade.json`` in ``--out``.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from robodyn.grade import load_assignment
from robodyn.grade.outputs import find_submissions, grade_class

from _common import argument_parser, output_folder, run_facts, write_json

ROOT = Path(__file__).resolve().parents[1]
FORMULAS = ROOT / "examples/formulas"
DOUBLE = (ROOT / "examples/grading/double_pendulum/solution.py").read_text()
PENDUBOT = (FORMULAS / "pendubot_mine.py").read_text()
THREE = (ROOT / "examples/grading/three_link/solution.py").read_text()
COORDS = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}  # q_formula = sign * q_urdf + offset'
MATRIX = "COORDINATES = [[1, 0], [0, -1]]\nOFFSETS = [math.pi / 2, 0.0]"
M12, M12_DROPPED = "m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2", "m12 = m2 * lc2**2 + I2"
HOSTILE = {
    "loops": ("def mass_matrix(q, p):", "def mass_matrix(q, p):\n    while True:\n        pass"),
    "exits": ("import math", "import math\nimport sys\nsys.exit(3)"),
    "writes": ("def gravity(q, p):", "def gravity(q, p):\n    open('pwned.txt', 'w').write('x')"),
    "socket": ("import math", "import math\nimport socket"),
}


def _with(text: str, *changes: tuple[str, str]) -> str:
    for old, new in changes:
        if old not in text:
            raise SystemExit(f"bench_grade: the example changed: {old!r} is gone")
        text = text.replace(old, new)
    return text


def _variants() -> dict[str, tuple[str, dict[str, tuple[str, float]]]]:
    """robot -> (assignment TOML, {variant: (file text, planted score)})."""
    double = {
        "right_dict": (DOUBLE, 10.0),
        "right_matrix": (_with(DOUBLE, (COORDS, MATRIX)), 10.0),
        "m12": (_with(DOUBLE, (M12, M12_DROPPED)), 9.0),
        "m12_and_c": (_with(DOUBLE, (M12, M12_DROPPED), ('h = -p["m2"]', 'h = p["m2"]')), 6.0),
        "nan": (_with(DOUBLE, ("    return np.array([(m1", "    return np.nan * np.array([(m1")), 0.0),
        **{k: (_with(DOUBLE, change), 0.0) for k, change in HOSTILE.items()},
    }
    pendubot = {
        "right": (PENDUBOT, 6.0),
        "right_cv": ((FORMULAS / "pendubot_cv.py").read_text(), 6.0),
        "g1": (_with(PENDUBOT, ("t5 * np.cos(q[0] + q[1])])", "0.0])")), 5.0),
    }
    three = {"right": (THREE, 12.0)}
    return {
        "double": (f'model = "{ROOT}/examples/urdf/double_pendulum.urdf"\ntime_limit = 3\n'
                   "[points]\nM = 3\nC = 4\nG = 2\nV = 1\n", double),
        "pendubot": ('model = "pendubot"\nchristoffel = false\n[points]\nM = 2\nC = 2\nG = 2\n', pendubot),
        "three": (f'model = "{ROOT}/examples/urdf/three_link_arm.urdf"\nchristoffel = false\n'
                  "[points]\nM = 6\nC = 3\nG = 3\n", three),
    }  # fmt: skip


def main() -> int:
    """Generate, grade, check every score, print and save."""
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--students", type=int, default=300, help="class size, over the three robots (default 300)")
    parser.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    args = parser.parse_args()
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    robots = _variants()
    wrong, graded, start, cpu_start = [], 0, time.perf_counter(), _cpu_seconds()
    with tempfile.TemporaryDirectory(prefix="bench-grade-") as tmp:
        for k, (robot, (toml, variants)) in enumerate(robots.items()):
            folder = Path(tmp) / robot
            (folder / "submissions").mkdir(parents=True)
            (folder / "assignment.toml").write_text(toml)
            names = list(variants)
            share = args.students // len(robots) + (k < args.students % len(robots))
            expected = {}
            for i in range(share):
                variant = names[i % len(names)]
                (folder / "submissions" / f"s{i:03d}_{variant}.py").write_text(variants[variant][0])
                expected[f"s{i:03d}_{variant}"] = variants[variant][1]
            assignment = load_assignment(folder / "assignment.toml")
            subs = find_submissions(folder / "submissions", assignment)
            results = grade_class(assignment, subs, folder / "out", jobs=args.jobs)
            graded += len(results)
            wrong += [(r.student, r.score, expected[r.student]) for r in results if r.score != expected[r.student]]
    wall, cpu = time.perf_counter() - start, _cpu_seconds() - cpu_start
    print(f"graded {graded} submissions over {len(robots)} robots in {wall:.1f} s with {args.jobs} processes "
          f"({wall / max(graded, 1):.2f} s a submission); scores not as planted: {len(wrong)} {wrong[:5]}")  # fmt: skip
    print(f"CPU time of this process and every process it started: {cpu:.1f} s ({cpu / args.jobs:.1f} s on "
          f"{args.jobs} otherwise idle cores)")  # fmt: skip
    result = {"students": graded, "jobs": args.jobs, "wall_s": wall, "per_submission_s": wall / max(graded, 1),
              "cpu_s": cpu, "not_as_planted": wrong}  # fmt: skip
    write_json(out, "bench_grade", result, facts)
    return 1 if wrong else 0


def _cpu_seconds() -> float:
    """User + system CPU time [s] of this process and of every process it started and waited for.

    The grading workers, and the formula processes each of them starts, all count: on a machine shared with other
    work the wall time measures the load as much as robodyn, and this does not.
    """
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


if __name__ == "__main__":
    sys.exit(main())
