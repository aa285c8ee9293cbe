"""``python -m cbrcore`` runs the ``cbr`` command line."""

from cbrcore.cli import console_main

console_main()
