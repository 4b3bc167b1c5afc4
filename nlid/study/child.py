"""``python -m nlid.study.child FOLDER``: one run in a fresh interpreter.

Used by :func:`nlid.study.worker.run_isolated` inside daemonic processes
(e.g. the workers of a default Dask cluster), which may not start
``multiprocessing`` children. Reads ``FOLDER/spec.json`` and writes
``FOLDER/payload.json`` (and ``FOLDER/arrays.npz``).
"""

import sys

from nlid.study.worker import subprocess_main

if __name__ == "__main__":
    sys.exit(subprocess_main(sys.argv[1]))
