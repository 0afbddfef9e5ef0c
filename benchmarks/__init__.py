"""Performance scripts (``python -m benchmarks.bench_<name>``).

Every benchmark runs on the numeric path the command-line tools use, pinned here before any
of them loads NumPy (see ``libero_data.numerics``).
"""

from libero_data.numerics import pin

pin()
