"""``python -m libero_bench.cli``: the same as ``libero-bench``."""

from libero_bench.cli import main

main()
