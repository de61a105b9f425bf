"""On-demand speed benchmarks (not timed tests): ``python -m benchmarks [NAME…]``.

Each ``benchmarks/bench_*.py`` module exposes ``main()``, which measures and prints its table.
"""
