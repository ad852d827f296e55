"""``python -m bridgefem``: the command line (:mod:`bridgefem.io.cli`), the same as the ``bridgefem`` command."""
from .io.cli import command

command()
