"""Input/output: the command line, results files, plots and the output-folder policy."""
