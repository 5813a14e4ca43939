"""Test-session settings shared by every test module."""
import os

import numba

# Under pytest-xdist (`pytest -n auto`) each worker is a process with numba's own thread
# pool: the workers share the machine's cores, at least two threads each so that the
# parallel kernels still run in parallel.
_workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
if _workers > 1:
    numba.set_num_threads(min(numba.config.NUMBA_NUM_THREADS,
                              max(2, (os.cpu_count() or 2) // _workers)))
