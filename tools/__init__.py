"""Long-running hardening scripts: ``make fuzz``, ``make storm``, ``make soak`` (not in CI)."""
