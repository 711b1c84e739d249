"""The :class:`Trajectory`: a simulated motion with its energy books and its power, saved to ``.npz``."""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError
from robodyn.fileio import write_atomically

Array = NDArray[np.float64]

# 2: adds ``work_limits`` (the energy the stops took) and ``power``; a version-1 file loads
# with work_limits = 0 (it was written by a run without stops). ``constraint_drift`` is an
# optional array of version 2: written by runs with loops only, None when absent.
FORMAT_VERSION = 2

# Every .npz starts with a zip local-file header.
_ZIP_MAGIC = b"PK\x03\x04"


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A simulated trajectory, sampled at ``n = len(t)`` instants.

    Arrays: ``t`` (n,) [s]; ``q`` (n, nq); ``v``, ``a``, ``tau`` (n, nv) in joint units;
    ``kinetic``, ``potential`` (n,) [J] (the potential includes the joint springs');
    ``work_input``, ``work_damping``, ``work_limits`` (n,) [J], cumulative work done by the
    applied torque, by damping/friction and by the joint stops since t[0] (the last two are
    negative: they remove energy; a stop takes 1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2) at each
    impact). ``tau`` is the applied torque (clamped at the efforts), and ``power`` (n, nv)
    = tau * v [W] per joint, ``power_total`` its sum: the rate of the input work (19.22-19.23).

    The books follow the principle of work and energy, U12 = T2 - T1, with gravity and the
    springs moved to the left as a potential: E(t) - E(0) = W_input + W_damping + W_limits.
    ``ledger_residual`` is what is left over; it is zero up to the integrator's accuracy.

    ``meta`` records the model (name, URDF path), the integrator, dt and backend, and
    ``wall_time_s`` and ``evaluations`` (dynamics calls) the cost of the run. ``status``
    is ``"ok"``, ``"diverged"`` or ``"interrupted"`` (Ctrl-C; then ``message`` says where
    and why). ``meta["q_units"]`` and ``meta["v_units"]`` give the unit of every entry of
    q and v ("rad", "m", "rad/s", "m/s", or "" for a cos/sin pair or a quaternion).

    ``constraint_drift`` (n,) [m] is, with closed loops, the worst loop residual norm
    ``max over loops |r_loop(q)|`` at each sample (rad enter a 6d loop's norm with its metres);
    None for a run without loops. Its maximum is ``meta["loop_drift"]``.
    """

    t: Array
    q: Array
    v: Array
    a: Array
    tau: Array
    kinetic: Array
    potential: Array
    work_input: Array
    work_damping: Array
    work_limits: Array | None = None
    wall_time_s: float = 0.0
    evaluations: int = 0
    status: str = "ok"
    message: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    constraint_drift: Array | None = None

    def __post_init__(self) -> None:
        if self.work_limits is None:  # a run without stops (or a file from before them)
            object.__setattr__(self, "work_limits", np.zeros_like(self.work_input))

    @property
    def stop_work(self) -> Array:
        """``work_limits`` as an array [J], shape (n,)."""
        return self.work_limits if self.work_limits is not None else np.zeros_like(self.work_input)

    @property
    def power(self) -> Array:
        """The input power tau_i v_i of every joint [W], shape (n, nv)."""
        return self.tau * self.v

    @property
    def power_total(self) -> Array:
        """The total input power tau . v [W], shape (n,); its integral over t is ``work_input``."""
        return np.einsum("ni,ni->n", self.tau, self.v)

    @property
    def average_power(self) -> float:
        """The input work over the elapsed time, W_input(T) / (T - t0) [W] (textbook Eq. 19.24)."""
        elapsed = float(self.t[-1] - self.t[0])
        return float(self.work_input[-1]) / elapsed if elapsed > 0 else 0.0

    @property
    def energy(self) -> Array:
        """Total mechanical energy T + V [J], shape (n,)."""
        return self.kinetic + self.potential

    @property
    def ledger_residual(self) -> Array:
        """E(t) - E(0) - W_input(t) - W_damping(t) - W_limits(t) [J], shape (n,)."""
        e = self.energy
        return e - e[0] - self.work_input - self.work_damping - self.stop_work

    @property
    def energy_drift(self) -> float:
        """Largest |E(t) - E(0)| [J]."""
        e = self.energy
        return float(np.max(np.abs(e - e[0])))

    @property
    def relative_energy_drift(self) -> float:
        """Largest |E(t) - E(0)| over max(|E(0)|, max T) (dimensionless)."""
        scale = max(abs(float(self.energy[0])), float(np.max(self.kinetic)), 1e-300)
        return self.energy_drift / scale

    @property
    def max_ledger_residual(self) -> float:
        """Largest |E(t) - E(0) - W_input(t) - W_damping(t) - W_limits(t)| [J]."""
        return float(np.max(np.abs(self.ledger_residual)))

    @property
    def n_steps(self) -> int:
        """Number of steps taken (samples minus one)."""
        return len(self.t) - 1

    @property
    def diverged(self) -> bool:
        """True when the run stopped early because the state blew up."""
        return self.status == "diverged"

    def summary(self) -> dict[str, Any]:
        """The figures ``robodyn simulate`` prints: steps, cost, final state, energy books."""
        e = self.energy
        return {
            "model": self.meta.get("model"),
            "integrator": self.meta.get("integrator"),
            "dt": self.meta.get("dt"),
            "status": self.status,
            "message": self.message,
            "steps": self.n_steps,
            "t_final": float(self.t[-1]),
            "wall_time_s": self.wall_time_s,
            "evaluations": self.evaluations,
            "q_final": self.q[-1].tolist(),
            "v_final": self.v[-1].tolist(),
            "q_units": self.meta.get("q_units"),
            "v_units": self.meta.get("v_units"),
            "energy_initial": float(e[0]),
            "energy_final": float(e[-1]),
            "energy_drift": self.energy_drift,
            "relative_energy_drift": self.relative_energy_drift,
            "work_input": float(self.work_input[-1]),
            "work_damping": float(self.work_damping[-1]),
            "work_limits": float(self.stop_work[-1]),
            "average_power": self.average_power,
            "max_ledger_residual": self.max_ledger_residual,
            "effort_clamped_samples": self.meta.get("effort_clamped_samples", 0),
            "impacts": self.meta.get("impacts", 0),
            "limit_violation": self.meta.get("limit_violation"),
            "loop_drift": self.meta.get("loop_drift"),
        }

    # ------------------------------------------------------------------ persistence
    _ARRAYS = ("t", "q", "v", "a", "tau", "kinetic", "potential", "work_input", "work_damping")
    _OPTIONAL = ("work_limits", "constraint_drift")  # absent from version-1 files; the drift from runs without loops

    def save(self, path: str | Path) -> Path:
        """Write to ``.npz`` (arrays plus ``energy`` and JSON metadata); return the path.

        The file appears complete or not at all: it is written next to ``path`` under a
        temporary name and renamed.

        Raises:
            InputError: ``path`` does not end in ``.npz``.
        """
        path = Path(path)
        if path.suffix != ".npz":
            raise InputError(f"{path}: expected a .npz path for a trajectory (got suffix {path.suffix!r})")
        arrays = {name: getattr(self, name) for name in (*self._ARRAYS, *self._OPTIONAL)}
        arrays = {name: value for name, value in arrays.items() if value is not None}
        info = {
            "format_version": FORMAT_VERSION,
            "wall_time_s": self.wall_time_s,
            "evaluations": self.evaluations,
            "status": self.status,
            "message": self.message,
            "meta": self.meta,
        }

        def write(fh: IO[bytes]) -> None:
            np.savez_compressed(fh, energy=self.energy, power=self.power, metadata=np.array(json.dumps(info)), **arrays)

        return write_atomically(path, write)

    def save_csv(self, path: str | Path) -> Path:
        """Write one row per sample: t, q_i, v_i, tau_i, kinetic, potential, energy, works, residual.

        Like :meth:`save`, the file appears complete or not at all.
        """
        path = Path(path)
        nq, nv = self.q.shape[1], self.v.shape[1]
        header = (
            ["t"]
            + [f"q{i}" for i in range(nq)]
            + [f"v{i}" for i in range(nv)]
            + [f"tau{i}" for i in range(nv)]
            + ["kinetic", "potential", "energy", "work_input", "work_damping", "work_limits", "power"]
            + ["ledger_residual"]
        )
        columns = [self.t, self.q, self.v, self.tau, self.kinetic, self.potential, self.energy]
        works = [self.work_input, self.work_damping, self.stop_work, self.power_total]
        table = np.column_stack([*columns, *works, self.ledger_residual])
        return write_atomically(
            path, lambda fh: np.savetxt(fh, table, delimiter=",", header=",".join(header), comments="", fmt="%.17g")
        )

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """Read a trajectory written by :meth:`save`.

        Every array is checked before and after it is read (:mod:`robodyn.sim.trajectory_file`):
        declared shapes and dtypes (no object arrays, nothing larger than its stored bytes), one
        row per sample, ``t`` strictly increasing, every value finite.

        Raises:
            InputError: no such file, or one that is not a trajectory .npz (empty, not a
                zip archive, arrays or metadata missing or malformed, of the wrong shape or type,
                non-finite numbers, times that repeat or go back); one line, naming what.
        """
        path = Path(path)
        expected = "expected an .npz written by robodyn simulate"
        if path.is_dir():
            raise InputError(f"{path}: is a folder, not a trajectory file ({expected})")
        if not path.is_file():
            raise InputError(f"{path}: no such trajectory file ({expected})")
        try:
            with path.open("rb") as fh:
                head = fh.read(len(_ZIP_MAGIC))
        except OSError as exc:
            raise InputError(f"{path}: cannot read it ({exc.strerror})") from None
        if not head:
            raise InputError(f"{path}: the file is empty, not a robodyn trajectory ({expected})")
        if head != _ZIP_MAGIC:
            raise InputError(f"{path}: not a robodyn trajectory: the file is not an .npz (zip) archive ({expected})")
        from robodyn.sim import trajectory_file as checks

        names = (*cls._ARRAYS, *cls._OPTIONAL, "metadata")
        try:
            headers = checks.array_headers(path, names)
            missing = [name for name in (*cls._ARRAYS, "metadata") if name not in headers]
            if missing:
                raise InputError(f"{path}: not a robodyn trajectory: no {', '.join(missing)} in it ({expected})")
            checks.check_dtypes(path, headers)
            with np.load(path, allow_pickle=False) as npz:
                arrays = {name: np.array(npz[name], dtype=np.float64) for name in names[:-1] if name in headers}
                info = json.loads(str(npz["metadata"]))
        except InputError:
            raise
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: not a robodyn trajectory: its metadata is not JSON ({exc.msg})") from None
        except RecursionError:
            raise InputError(f"{path}: not a robodyn trajectory: its metadata is nested too deeply") from None
        except MemoryError:
            raise InputError(f"{path}: its arrays do not fit in memory") from None
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, NotImplementedError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(f"{path}: not a robodyn trajectory: the archive is damaged ({reason[:160]})") from None
        checks.check_metadata(path, info)
        checks.check_arrays(path, arrays, finite=info.get("status", "ok") == "ok")
        known = {f.name for f in fields(cls)}
        # Metadata never overrides an array: a key such as 't' in a hand-made file is ignored.
        extra = {k: v for k, v in info.items() if k in known and k not in (*cls._ARRAYS, *cls._OPTIONAL)}
        return cls(**arrays, **extra)  # type: ignore[arg-type]
