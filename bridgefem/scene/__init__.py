"""Scene files: the schema of every key (default, unit, range), reading and validation into dataclasses."""
