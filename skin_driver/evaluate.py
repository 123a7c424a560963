"""Run the evaluator (skin_driver.tools.evaluate) as ``python -m skin_driver.evaluate``."""

import sys

from skin_driver.tools.evaluate.cli import main

if __name__ == '__main__':
    sys.exit(main())
