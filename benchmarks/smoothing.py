"""The smoothing benchmark (the CI benchmark of smoothing runs); the code lives in foam_mj.benchmark so
that the installed `foam-mj bench` runs it too.

    .venv/bin/python benchmarks/smoothing.py [--quick] [--json out.json]
"""

import sys

from foam_mj.benchmark import main

if __name__ == "__main__":
    sys.exit(main())
