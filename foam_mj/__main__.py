"""``python -m foam_mj ...``: the ``foam-mj`` command (for an environment whose scripts folder is not on PATH)."""

from foam_mj.cli import main

raise SystemExit(main())
