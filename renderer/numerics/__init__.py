"""The floor of the kernels: what every category and the tracing layer build on and which imports
nothing of theirs. 3-vectors (`vec`), counter-based random numbers (`rng`), discrete
distributions (`cdf`) and the four-wide box test (`simd`). Like all compiled code, declared
through renderer/target.py."""
