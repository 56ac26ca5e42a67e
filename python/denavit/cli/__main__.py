"""``python -m denavit.cli``: the ``denavit`` command."""

from . import main

main()
