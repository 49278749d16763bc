"""Benchmarks: each module prints tables of ratios measured side by side in one run."""
