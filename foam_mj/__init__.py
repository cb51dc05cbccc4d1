"""foam-mj: certified safe motion planning with the Probabilistic Foam Method over MuJoCo scenes."""

__version__ = "0.1.0"
