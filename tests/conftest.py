"""Import beamsim before any test module imports numpy, so the tests run with the same
single-threaded BLAS as the library and the workflow (see beamsim/__init__.py).

The order of the test files (``make test`` hands whole files to its two workers, in this
order): files marked ``waits`` first -- the SLURM test spends most of its two minutes waiting
on the executor's status polls, which overlap the other worker's computing only if it does not
run last (docs/architecture.md) --, then files with ``slow`` tests, then the rest, the files
with more tests first (pytest-xdist's own order)."""

import beamsim  # noqa: F401


def pytest_collection_modifyitems(config, items):
    by_file: dict[str, list] = {}
    for item in items:
        by_file.setdefault(item.nodeid.split("::")[0], []).append(item)

    def rank(path: str) -> tuple[bool, bool, int]:
        its = by_file[path]
        return (not any(i.get_closest_marker("waits") for i in its),
                not any(i.get_closest_marker("slow") for i in its), -len(its))

    items[:] = [item for path in sorted(by_file, key=rank) for item in by_file[path]]
