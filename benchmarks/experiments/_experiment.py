"""What every experiment here imports first: ``benchmarks/_common.py``'s helpers, writing under ``experiments/results/``."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import _common  # noqa: E402

_common.RESULTS = Path(__file__).resolve().parent / "results"
