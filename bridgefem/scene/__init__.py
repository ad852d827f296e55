"""Scene files: the schema of every key (default, unit, range), reading and validation into dataclasses.

:mod:`~bridgefem.scene.schema` (the keys: ``SCHEMA``), :mod:`~bridgefem.scene.keys` (a key's type and check),
:mod:`~bridgefem.scene.model` (the dataclasses, ``Scene``), :mod:`~bridgefem.scene.reader` (``load_scene``,
``scene_from_dict``), :mod:`~bridgefem.scene.document` (editing a scene as its file).
"""
