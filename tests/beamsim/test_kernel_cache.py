"""numba's cache folder follows beamsim's sources (``beamsim/__init__.py``): numba invalidates
a cached kernel when its own file changes, not when a callee in another file does, so a folder
shared across versions of the sources ran kernels that mixed them (docs/reliability.md,
"Compiled kernels")."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import beamsim

PROBE = "import beamsim, numba, os; print(numba.config.CACHE_DIR); print(os.environ['NUMBA_CACHE_DIR'])"


def _folder(pythonpath: Path, cache: str | None, numba_first: bool = False) -> str:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(pythonpath)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    probe = ("import numba; " + PROBE) if numba_first else PROBE
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True,
                         check=True, cwd=pythonpath).stdout.strip().splitlines()
    assert out[-1] == out[-2]            # numba's setting and what child processes inherit
    return out[-1]


def test_the_cache_folder_changes_with_any_source_file_and_only_with_them(tmp_path):
    src = tmp_path / "copy"
    shutil.copytree(Path(beamsim.__file__).parent, src / "beamsim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    first = _folder(src, None)
    assert Path(first).parent == src / "beamsim" / "__pycache__" / "numba"
    assert Path(first).name.startswith("beamsim-") and Path(first).is_dir()
    assert _folder(src, None) == first
    # a comment in one kernel file: another folder (the kernels of other files that call it
    # are compiled again too)
    kernel = src / "beamsim" / "kernels" / "expo.py"
    kernel.write_text(kernel.read_text() + "\n# an edit\n")
    edited = _folder(src, None)
    assert edited != first and Path(edited).parent == Path(first).parent
    # a user's NUMBA_CACHE_DIR is the base; numba imported first is configured too; a child
    # process that inherits the folder keeps it
    user = _folder(src, str(tmp_path / "user"))
    assert user == str(tmp_path / "user" / Path(edited).name)
    assert _folder(src, str(tmp_path / "user"), numba_first=True) == user
    assert _folder(src, user) == user
    # a relative base is made absolute (a child process may run in another folder)
    assert _folder(src, "rel") == str(src / "rel" / Path(edited).name)
