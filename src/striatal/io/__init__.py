"""Files: atomic, data-only JSON and CSV I/O and the layout of a training run's folder.

Owns every file format the library reads or writes: settings with a schema version,
checkpoints, ``history.csv`` and ``result.json``. The command line and the Python API
read and write run folders only through here.
"""
