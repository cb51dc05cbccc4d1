"""The smoothing benchmark (the CI benchmark of smoothing runs); the code lives in foam_mj.benchmark so
that the installed `foam-mj bench` runs it too.

    .venv/bin/python benchmarks/smoothing.py [--quick] [--json out.json]
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import run_script  # noqa: E402

from foam_mj.benchmark import main  # noqa: E402

if __name__ == "__main__":
    run_script(main)
