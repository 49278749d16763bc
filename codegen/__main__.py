"""``python -m codegen`` runs the ``codecgen`` command."""

from codegen.cli import main_entry

main_entry()
