"""pytest fixtures shared by the integration tests (run with
`/usr/bin/python3 -m pytest tests/integration`; `make test` runs them too).

Run directories come from pytest's tmp_path_factory: pytest keeps the
directories of its last three sessions under /tmp/pytest-of-$USER for
inspection and removes older ones."""
import pytest


@pytest.fixture(scope="session")
def scratch(tmp_path_factory):
    """scratch(prefix): a fresh, empty directory for one or more runs.
    Session-scoped so that module-scoped fixtures (a case run once and
    shared by a module's tests) can use it too."""
    return lambda prefix: tmp_path_factory.mktemp(prefix)
