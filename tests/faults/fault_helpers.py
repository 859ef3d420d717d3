"""What the fault tests share: run one command in-process as a terminal shows it, and snapshot a tree."""

from __future__ import annotations

import logging
import re
import sys
from pathlib import Path

from mnss_kit.cli import main

SUMMARY = re.compile(r": \d+ problems?$")  # bundle check's closing count, after its problem lines


def run_cli(argv: list, capture) -> tuple[int, list[str], str]:
    """Exit status, stderr lines (log records included, bundle check's count left out) and stdout of
    one command.  ``capture`` is capsys, or capfd where a C library may write to the descriptors."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    logging.getLogger().addHandler(handler)
    try:
        capture.readouterr()
        code = main([str(a) for a in argv])
    finally:
        logging.getLogger().removeHandler(handler)
    out, err = capture.readouterr()
    assert "Traceback" not in err and "Traceback" not in out
    return code, [line for line in err.splitlines() if line.strip() and not SUMMARY.search(line)], out


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` (directories as None) with its bytes."""
    return {p.relative_to(root).as_posix(): p.read_bytes() if p.is_file() else None for p in sorted(root.rglob("*"))}


def assert_one_line_fault(argv: list, words: list[str], status: int, scratch: Path, capture) -> str:
    """The command fails with ``status`` and one stderr line holding ``words``; nothing under
    ``scratch`` changes and no ``scratch/out`` appears.  Returns the line."""
    before = snapshot(scratch)
    code, lines, _ = run_cli(argv, capture)
    assert code == status, (code, lines)
    assert len(lines) == 1, lines
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert not (scratch / "out").exists()
    assert snapshot(scratch) == before  # inputs unchanged, nothing partial beside them
    return lines[0]
