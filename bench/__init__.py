"""Benchmarks: scripts that print ratios against anchors measured side by side."""
