"""``python -m libero_data.cli``: the same as ``libero-data``."""

from libero_data.cli import main

main()
