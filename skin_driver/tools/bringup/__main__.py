"""``python -m skin_driver.tools.bringup``: check a new board (docs/firmware.md)."""

import sys

from .cli import main

sys.exit(main())
