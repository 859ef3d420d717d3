"""Generated blocks of the docs: the text between ``<!-- BEGIN GENERATED: NAME -->`` and
``<!-- END GENERATED: NAME -->``, rewritten by the script that measures it."""

from __future__ import annotations

import re
from pathlib import Path


def replace_block(text: str, name: str, body: str, doc: Path) -> str:
    """``text`` (the contents of ``doc``) with block ``name`` replaced by ``body``."""
    pattern = re.compile(rf"(<!-- BEGIN GENERATED: {name} -->\n).*?(<!-- END GENERATED: {name} -->)", re.S)
    if not pattern.search(text):
        raise SystemExit(f"{doc}: no generated block '{name}'")
    return pattern.sub(lambda mt: mt.group(1) + body.rstrip("\n") + "\n" + mt.group(2), text)
