#!/usr/bin/env python
"""Render shipped data configs and run ``data check`` on each: the toolkit's renders must pass its own check.

    python scripts/check_data_configs.py OUT                 # every mnss_kit/configs/data/*.yaml
    python scripts/check_data_configs.py OUT train_x2 test_x2

The tests cover the tiny configs (tests/faults/test_render_faults.py); this covers the large ones,
which take minutes each on a CPU rasteriser.  Renders use one HR sample (``--set hr_samples=1``):
motion, depth and the reset flags do not depend on it, only the HR reference's anti-aliasing does.
An existing ``OUT/NAME`` is resumed.  Exits 1 when any config fails its check.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mnss_kit.cli import main
from mnss_kit.config import CONFIG_DIR


def check(config: str, out: Path) -> int:
    target = out / config
    if main(["render", config, "--out", str(target), "--set", "hr_samples=1", "--no-progress"]) != 0:
        return 1
    return main(["data", "check", str(target)])


def run(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="directory for the renders (one sub-directory per config)")
    parser.add_argument("configs", nargs="*", help="data config names (default: every mnss_kit/configs/data/*.yaml)")
    args = parser.parse_args(argv)
    configs = args.configs or sorted(p.stem for p in (CONFIG_DIR / "data").glob("*.yaml"))
    failed = [c for c in configs if check(c, args.out) != 0]
    print(f"{len(configs) - len(failed)} of {len(configs)} data configs pass data check" + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(run())
