"""Runnable examples: ``python -m examples.talker``/``listener`` and ``python -m examples.demo``."""
