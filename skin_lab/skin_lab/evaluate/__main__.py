"""Run the evaluator as ``python -m skin_lab.evaluate`` (its command line: :mod:`.cli`)."""

import sys

from skin_lab.evaluate.cli import main

if __name__ == '__main__':
    sys.exit(main())
