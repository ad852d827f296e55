"""``python -m bridgefem``: the command line (:mod:`bridgefem.io.cli`), the same as the ``bridgefem`` command."""
import sys

from .io.cli import main

sys.exit(main())
