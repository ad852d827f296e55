"""Input/output: :mod:`~bridgefem.io.cli` (the command line), :mod:`~bridgefem.io.commands` (``converge`` and
``bounds``), :mod:`~bridgefem.io.results` (results.json, fields.xdmf), :mod:`~bridgefem.io.lp_report` (the LP as
reported), :mod:`~bridgefem.io.plots` and :mod:`~bridgefem.io.bounds_plot` (PNG plots) and
:mod:`~bridgefem.io.output` (where and how files are written), with :mod:`~bridgefem.io.targets` (which targets
may be written) and :mod:`~bridgefem.io.lock` (one run per target)."""
