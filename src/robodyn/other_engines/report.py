"""The result of ``robodyn.against``: per engine and reading, the differences, their causes, their effects."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robodyn.errors import MissingDependencyError

AGREE, DIFFER, REFUSED = "agree", "differ", "refused"


@dataclass(frozen=True)
class Cause:
    """One difference: where (link and joint), what and why in one line, its effect and the option removing it.

    ``effect`` maps ``M``, ``Cv``, ``G`` to the largest change this difference alone makes to robodyn's
    values, relative to each quantity's largest entry over the states.
    """

    where: str
    what: str
    option: str | None
    effect: dict[str, float]


@dataclass(frozen=True)
class Comparison:
    """One engine's reading (default or trusted) against robodyn's.

    ``differences``: the largest relative difference of M, C v and G over the states. ``unexplained``: what is
    left once every cause is applied to robodyn's model (None when nothing is). ``refused``: the engine's own
    message when it refused the file (then nothing else is filled in).
    """

    engine: str
    version: str
    reading: str
    option: str
    differences: dict[str, float]
    causes: tuple[Cause, ...]
    unexplained: dict[str, float] | None
    refused: str | None
    seconds: float

    @property
    def status(self) -> str:
        """``agree``, ``differ`` or ``refused``."""
        if self.refused is not None:
            return REFUSED
        return DIFFER if self.causes or self.unexplained is not None else AGREE


@dataclass(frozen=True)
class AgainstReport:
    """Every comparison of one robot; ``seconds`` is the wall time of the whole check."""

    model: str
    rtol: float
    samples: int
    seed: int
    comparisons: tuple[Comparison, ...]
    seconds: float

    @property
    def status(self) -> str:
        """``refused`` if an engine refused the file, else ``differ`` if any reading differs, else ``agree``."""
        found = {c.status for c in self.comparisons}
        return REFUSED if REFUSED in found else DIFFER if DIFFER in found else AGREE

    def as_dict(self) -> dict[str, Any]:
        """Plain data for JSON."""
        return {
            "model": self.model,
            "rtol": self.rtol,
            "samples": self.samples,
            "seed": self.seed,
            "status": self.status,
            "seconds": self.seconds,
            "comparisons": [
                {
                    "engine": c.engine,
                    "version": c.version,
                    "reading": c.reading,
                    "option": c.option,
                    "status": c.status,
                    "differences": c.differences,
                    "causes": [vars(cause) for cause in c.causes],
                    "unexplained": c.unexplained,
                    "refused": c.refused,
                    "seconds": c.seconds,
                }
                for c in self.comparisons
            ],
        }

    def to_dataframe(self) -> Any:
        """:meth:`rows` as a pandas DataFrame.

        Raises:
            MissingDependencyError: pandas is not installed.
        """
        try:
            import pandas as pd
        except ImportError:
            raise MissingDependencyError("AgainstReport.to_dataframe needs pandas: pip install pandas") from None
        return pd.DataFrame(self.rows())

    def rows(self) -> list[dict[str, Any]]:
        """One row per cause (or per agreeing or refusing reading).

        Keys: engine, reading, status, where, cause, option, M, Cv, G.
        """
        rows: list[dict[str, Any]] = []
        for c in self.comparisons:
            head = {"engine": c.engine, "reading": c.reading, "status": c.status}
            for cause in c.causes:
                rows.append({**head, "where": cause.where, "cause": cause.what, "option": cause.option, **cause.effect})
            if c.unexplained is not None:
                rows.append({**head, "where": "", "cause": "unexplained", "option": None, **c.unexplained})
            if not c.causes and c.unexplained is None:
                rows.append({**head, "where": "", "cause": c.refused or "", "option": None, **c.differences})
        return rows


def format_report(report: AgainstReport) -> str:
    """The text ``robodyn check MODEL --against ENGINE`` prints."""
    lines = [f"{report.model}: {report.samples} seeded states (seed {report.seed}), rtol {report.rtol:g}"]
    for c in report.comparisons:
        title = f"{c.engine} {c.version}, {c.reading} reading" + (f" ({c.option})" if c.option else "")
        if c.refused is not None:
            lines.append(f"  {c.engine}, {c.reading} reading: REFUSED: {c.refused}")
            continue
        sizes = ", ".join(f"{_name(k)} {v:.1e}" for k, v in c.differences.items())
        lines.append(
            f"  {title}: {c.status.upper() if c.status != 'agree' else 'agrees'} (largest relative difference: {sizes})"
        )
        for cause in c.causes:
            effect = ", ".join(f"{_name(k)} {v:.1e}" for k, v in cause.effect.items())
            shown = f" [effect: {effect}]"
            if not any(cause.effect.values()):  # a joint's limit or friction says so in its own words
                nil = "no effect on M, C v, G" in cause.what
                shown = "" if nil else f" [effect: none on M, C v, G beyond rtol {report.rtol:g}]"
            removed = f"; removed by {cause.option}" if cause.option else ""
            lines.append(f"    {cause.where}: {cause.what}{shown}{removed}")
        if c.unexplained is not None:
            left = ", ".join(f"{_name(k)} {v:.1e}" for k, v in c.unexplained.items())
            lines.append(f"    unexplained: a difference no named cause accounts for ({left})")
    verdict = {
        "agree": "every engine agrees with robodyn",
        "differ": "an engine differs",
        "refused": "an engine refused the file",
    }
    lines.append(f"{verdict[report.status]} ({report.seconds:.2f} s)")
    return "\n".join(lines)


def _name(key: str) -> str:
    return {"Cv": "C v"}.get(key, key)
