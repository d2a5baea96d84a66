"""Root pytest configuration: no screen is needed (matplotlib draws with Agg)."""
import os

os.environ.setdefault("MPLBACKEND", "Agg")
