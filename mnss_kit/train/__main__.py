"""``python -m mnss_kit.train CONFIG ...``: the train command, for launchers such as torchrun.

    torchrun --nproc_per_node=2 -m mnss_kit.train mnss_x2 --out runs/x2
"""

import sys

from ..cli import main

if __name__ == "__main__":
    sys.exit(main(["train", *sys.argv[1:]]))
