"""Write imported datasets atomically and check them before they appear at the output."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ...errors import UserError
from ...fileio import atomic_directory
from ..check import check_dataset


@dataclass
class ImportResult:
    datasets: list[str]  # the dataset directories written (OUT, or OUT/x{ratio} for NSS)
    sequences: int
    frames: int
    notes: list[str]  # what was not imported and why
    warnings: list[str]  # data check's warnings on the imported data


def publish(out: str | Path, write: Callable[[Path], list[Path]], overwrite: bool = False) -> list[str]:
    """Run ``write(staging)`` (it returns the dataset directories it wrote inside ``staging``), check
    each with ``data check``'s checks, then move ``staging`` to ``out``.  Any error leaves ``out`` as it was.

    Returns the warnings of the check, one line each.
    """
    warnings = []
    with atomic_directory(out, overwrite=overwrite) as staging:
        datasets = write(staging)
        for root in datasets:
            report = check_dataset(root, progress=False)
            for problem in report.problems:  # name the files as they will be in ``out``
                problem.where = (root.relative_to(staging) / problem.where).as_posix()
            if report.errors:
                raise UserError(f"the imported data fails data check ({len(report.errors)} error(s)), "
                                f"first: {report.errors[0].line()}")
            warnings += [p.line() for p in report.warnings]
    return warnings


