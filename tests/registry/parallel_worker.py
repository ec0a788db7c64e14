"""Writer processes of ``test_parallel_writers.py`` (run as a script, not collected).

Usage: parallel_worker.py URI SIGNATURE_JSON CALIBRATION_JSON PROCESSES FITS ASSETS

Imports everything once, then forks PROCESSES writer processes (as a pre-loading server
does; nothing has opened the store before the fork, so each child has its own SQLite
connections). The children start together, each records FITS baseline fits spread over
ASSETS assets and commits each watermark. Prints ``retries=<n>`` (the "database is locked"
retries needed) and exits 1 if any child failed.
"""
from __future__ import annotations

import logging
import os
import pathlib
import sys
import time
import traceback

import pandas as pd

import mlflow.pyfunc  # noqa: F401  (pre-loaded before the fork, as the children need them)
import mlflow.store.model_registry.sqlalchemy_store  # noqa: F401
import mlflow.store.tracking.sqlalchemy_store  # noqa: F401

from graybox.calibration import Calibration
from graybox.signature import Signature
from registry import Registry
from registry.write.run_content import code_version


class _Count(logging.Handler):
    def __init__(self):
        super().__init__()
        self.retries = 0

    def emit(self, record):
        if "database is locked" in record.getMessage():
            self.retries += 1


def child(uri: str, signature: Signature, calibration: Calibration, start_at: float,
          worker: int, fits: int, assets: int) -> int:
    counter = _Count()
    logging.getLogger("registry").addHandler(counter)
    registry = Registry(uri, user=f"worker-{worker}")
    time.sleep(max(0.0, start_at - time.time()))
    for k in range(fits):
        asset = f"P-{(worker + k) % assets:02d}"
        start = pd.Timestamp("2026-02-01", tz="UTC") + pd.Timedelta(days=worker * fits + k)
        end = start + pd.Timedelta(days=1)
        registry.record_fit(asset, "turbine", signature, role="baseline", calibration=calibration,
                            window_start=start, window_end=end, data_hash=f"w{worker}-{k}",
                            plots=False)
        registry.commit_watermark(asset, end)
    # one write of the whole line: the children share the pipe, and print's separate writes
    # of the text and the newline interleave between processes (a write under PIPE_BUF is atomic)
    os.write(sys.stdout.fileno(), f"worker {worker} retries={counter.retries}\n".encode())
    return 0


def main(uri: str, signature_path: str, calibration_path: str, processes: int, fits: int,
         assets: int) -> int:
    signature = Signature.from_json(pathlib.Path(signature_path).read_text())
    calibration = Calibration.from_json(pathlib.Path(calibration_path).read_text())
    code_version()                                        # cached before the fork
    start_at = time.time() + 0.5 + 0.05 * processes      # every child starts writing together
    children = {}
    for worker in range(processes):
        pid = os.fork()
        if pid == 0:
            code = 1
            try:
                code = child(uri, signature, calibration, start_at, worker, fits, assets)
            except BaseException:
                traceback.print_exc()
                sys.stderr.flush()
            finally:
                sys.stdout.flush()
                os._exit(code)
        children[pid] = worker
    failed = []
    for pid, worker in children.items():
        _, status = os.waitpid(pid, 0)
        if os.waitstatus_to_exitcode(status) != 0:
            failed.append(worker)
    print(f"processes={processes} failed={failed}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    uri, signature_path, calibration_path, processes, fits, assets = sys.argv[1:]
    sys.exit(main(uri, signature_path, calibration_path, int(processes), int(fits), int(assets)))
