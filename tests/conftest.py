"""Shared test set-up: the `slow` marker.

A test is slow when it compiles or loads the render kernels, or starts processes. `pytest -m
"not slow"` runs the rest (models, graph, loading, flattening, the naive references) in under
a minute; the README's test command runs everything.
"""


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: compiles or loads the render kernels, or starts processes")


README_TEST = "tests/test_readme.py::test_the_readme_runs_as_shown"


def pytest_collection_finish(session):
    """Start the README's run at once when it is among the tests to run: it waits on one process
    at a time, so it overlaps the rest of the suite (tests/test_readme.py, BackgroundRun)."""
    if any(item.nodeid == README_TEST for item in session.items):
        from tests.test_readme import start_in_background

        start_in_background()
