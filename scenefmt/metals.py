"""Measured metals by name: their complex index of refraction per RGB channel."""

# name -> (eta RGB, k RGB, source)
METALS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float], str]] = {
    "aluminium": ((1.657, 0.880, 0.521), (9.224, 6.270, 4.837), "placeholder until the measured table lands"),
}
