"""Shared test set-up: the `slow` marker.

A test is slow when it compiles or loads the render kernels, or starts processes. `pytest -m
"not slow"` runs the rest (models, graph, loading, flattening, the naive references) in under
a minute; the README's test command runs everything.
"""


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: compiles or loads the render kernels, or starts processes")
