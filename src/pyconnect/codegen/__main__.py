"""``python -m pyconnect.codegen`` runs the ``codecgen`` command."""

from pyconnect.codegen.cli import main_entry

main_entry()
