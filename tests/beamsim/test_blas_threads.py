"""BLAS/LAPACK run on one thread in any process that imports beamsim, whatever the environment
says: threaded LAPACK rounds differently, and Snakemake sets ``OPENBLAS_NUM_THREADS`` to a job's
thread count, which made a four-mode run of the workflow differ between ``-c1`` and ``-c2``
(docs/pipeline.md, "Incremental runs and reproducibility")."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

PROBE = """
import json, sys
{before}
import beamsim
import numpy, scipy.linalg  # scipy's own OpenBLAS is loaded here, after beamsim, unless before
from threadpoolctl import threadpool_info
print(json.dumps([[i["internal_api"], i["num_threads"]] for i in threadpool_info()
                  if i["user_api"] == "blas"]))
"""


@pytest.mark.parametrize("before", ["", "import numpy, scipy.linalg"],
                         ids=["beamsim first", "numpy and scipy first"])
def test_blas_is_single_threaded_whatever_the_environment(before: str) -> None:
    env = os.environ | {"OPENBLAS_NUM_THREADS": "4", "MKL_NUM_THREADS": "4"}
    out = subprocess.run([sys.executable, "-c", PROBE.format(before=before)], env=env,
                         capture_output=True, text=True, check=True).stdout
    libs = json.loads(out.strip().splitlines()[-1])
    assert libs, "no BLAS library found"
    assert all(n == 1 for _, n in libs), libs
