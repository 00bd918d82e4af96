"""Benchmarks behind ``mrs-nav bench``: one module per benchmark, results into ``bench/RESULTS.md``."""
