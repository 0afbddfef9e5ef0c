"""LIBERO's own HDF5 demonstration files: reading them, and what ``libero-data import`` checks.

LIBERO ships its human demonstrations as one HDF5 file per task, written by its
``scripts/create_dataset.py``. :mod:`~libero_data.hdf5.reader` reads that layout (and refuses
anything else in one sentence), :mod:`~libero_data.hdf5.fixtures` places a file's fixtures from
the model XML it stores and finds the task in our registry from its BDDL, and
:mod:`~libero_data.hdf5.checks` measures how the stored states replay under our simulator,
which stored init state each demonstration began nearest to, and its no-op frames.
"""
