"""robodyn: rigid-body dynamics of any robot over HTTP, on Pinocchio."""

import os

# Pinocchio's OpenMP batch algorithms (rneaInParallel, abaInParallel) run in short chunks so
# that the event loop keeps answering; by default libgomp's idle threads spin between calls and
# take the cores the event loop needs (measured: chunked batches 2–3× slower, single requests
# delayed). Passive waiting must be chosen before libgomp loads, i.e. before pinocchio is
# imported, hence here. An explicit OMP_WAIT_POLICY in the environment wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "0.1.0"
