"""``python -m skin_driver.tools.rehost``: the rehosted Nucleo board on a pty."""

import sys

from .board import main

sys.exit(main())
