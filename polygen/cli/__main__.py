"""``python -m polygen.cli``: the ``polygen`` command."""

import sys

from polygen.cli import main

sys.exit(main())
