"""``python -m polygen.cli``: the ``polygen`` command."""

import sys

from polygen.cli import main

if __name__ == "__main__":  # not when a tool imports every module (the API reference does)
    sys.exit(main())
