"""numba's optimisation level: beamsim sets 1 unless the environment chose one (a compile-speed
knob: docs/performance.md, "numba at optimisation level 1")."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PROBE = "import beamsim, numba; print(int(numba.config.OPT))"


@pytest.mark.parametrize("given, expected", [(None, 1), ("3", 3), ("2", 2)],
                         ids=["unset", "user's 3", "user's 2"])
def test_opt_level_defaults_to_one_and_respects_the_environment(given, expected) -> None:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    if given is not None:
        env["NUMBA_OPT"] = given
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert int(out.strip().splitlines()[-1]) == expected
